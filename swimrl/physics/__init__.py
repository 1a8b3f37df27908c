"""Swimmer physics: equations of motion and Heun step (:mod:`.swimmer`), body-frame signals
(:mod:`.signals`), the drag factor of the swimmer's shape (:mod:`.energy`), the
decision-interval integrator (:mod:`.integrator`) and its fused CPU kernel (:mod:`.kernels`)."""
