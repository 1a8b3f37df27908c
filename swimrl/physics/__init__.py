"""Swimmer physics: equations of motion and Heun step (:mod:`.swimmer`), body-frame signals
(:mod:`.signals`), the decision-interval integrator (:mod:`.integrator`) and its fused CPU
kernel (:mod:`.kernels`)."""
