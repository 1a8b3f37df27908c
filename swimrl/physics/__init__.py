"""Swimmer physics: equations of motion and Heun step (:mod:`.swimmer`, :mod:`.swimmer3d`), the
swimmer's body by dimension (:mod:`.body`, :mod:`.body2d`, :mod:`.body3d`), the gyrotactic
torque of a bottom-heavy swimmer (:mod:`.gyrotaxis`), the tumbling rate (:mod:`.tumbling`),
the drag factor of the swimmer's shape (:mod:`.energy`), the decision-interval integrators
(:mod:`.integrator`, :mod:`.point_integrator`) and their fused CPU kernels (:mod:`.kernels`)."""
