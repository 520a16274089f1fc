"""The line-throwing rocket (Lu et al. 2016): a rocket pulls a rope out of a box in flight.

* :mod:`~jaxcable.throw.rocket`: the point-mass rocket with thrust and burning mass;
* :mod:`~jaxcable.throw.forces`: gravity, thrust, drag, ground and the pull-out force, one component each;
* :mod:`~jaxcable.throw.scene`: the scene, its builder with calibrated defaults, its outputs;
* :mod:`~jaxcable.throw.calibration`: fitting unknown coefficients to the flight test (optax);
* :mod:`~jaxcable.throw.design`: the launch design problem (angle, rope diameter);
* :mod:`~jaxcable.throw.plotting`: trajectory, speed and rope-shape plots.
"""

from jaxcable.throw.rocket import PointRocket, paper_rocket
from jaxcable.throw.scene import CALIBRATION, Launch, LineThrowingScene, line_throwing_scene, with_angle
from jaxcable.throw import design  # noqa: F401  (registers the "throw" design problem)
from jaxcable.throw import bench_cases  # noqa: F401  (registers the bench case)

__all__ = ["CALIBRATION", "Launch", "LineThrowingScene", "PointRocket", "line_throwing_scene", "paper_rocket", "with_angle"]
