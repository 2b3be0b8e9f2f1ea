"""Model-based control in pure JAX: iLQR, the paper's "standard controller" (Fig. 5).

* :func:`ilqr` — iterative LQR for ``x' = f(x, u)`` and cost ``Σ l(x, u, t) + l_f(x_T)``, with
  Levenberg–Marquardt regularisation, a vectorised line search and action bounds by a box-QP;
  jittable and vmappable (spec ``algorithms.md`` §5).
* :func:`goal_tracking_cost`, :func:`target_reaching_cost` — cost builders.
* :func:`solve_task` — iLQR on any hiddpg environment through its ``dynamics`` and goal space.
* :func:`box_qp` — the box-constrained QP that handles the action bounds.
"""

from hiddpg.control.box_qp import box_qp
from hiddpg.control.costs import (
    Cost,
    goal_schedule,
    goal_tracking_cost,
    solve_task,
    target_reaching_cost,
)
from hiddpg.control.ilqr import (
    Derivatives,
    ILQRConfig,
    ILQRResult,
    ilqr,
    linearize,
)

__all__ = [
    "Cost",
    "Derivatives",
    "ILQRConfig",
    "ILQRResult",
    "box_qp",
    "goal_schedule",
    "goal_tracking_cost",
    "ilqr",
    "linearize",
    "solve_task",
    "target_reaching_cost",
]
