"""The line-throwing rocket's benchmark case for ``jaxcable bench`` (:mod:`jaxcable.studies.bench`).

=============  =====================================================================================
scene          quantities
=============  =====================================================================================
``throw``      range [m], max speed [m/s], flight time [s] (line-throwing rocket, to ground impact)
=============  =====================================================================================

Registered at import: ``"throw"`` (5 m rope segments, 30 s: the flight ends at impact, ~9.2 s).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import equinox as eqx

from jaxcable.core.validation import check_positive
from jaxcable.studies import registry
from jaxcable.studies.bench import AbstractBenchCase, simulation_runner
from jaxcable.throw.scene import line_throwing_scene

__all__ = ["ThrowBenchCase"]


class ThrowBenchCase(AbstractBenchCase):
    """The line-throwing rocket pulling its rope out of the box, to ground impact.

    Attributes:
        level: ``"segments"`` (the finite-segment rope).
        t_end_s: latest time [s] (the flight ends at impact, ~9.2 s at 30 deg).
        segment_length_m: rope segment length [m].
        rope_length_m: rope in the box [m] (sets the array sizes).
        angle_deg: launch elevation [deg].
    """

    segment_length_m: float = eqx.field(static=True, default=1.0)
    rope_length_m: float = eqx.field(static=True, default=750.0)
    angle_deg: float = eqx.field(static=True, default=30.0)

    scene: ClassVar[str] = "throw"
    levels: ClassVar[tuple[str, ...]] = ("segments",)
    quantities: ClassVar[tuple[str, ...]] = ("range_m", "max_speed_mps", "flight_time_s")

    def __check_init__(self):
        check_positive("segment_length_m", self.segment_length_m)
        check_positive("rope_length_m", self.rope_length_m)

    @property
    def label(self) -> str:
        return f"{self.segment_length_m:g} m segments"

    def runner(self) -> Callable:
        scene = line_throwing_scene(self.angle_deg, self.segment_length_m, self.rope_length_m)
        return simulation_runner(scene, self.t_end_s, self.quantities)


# sized to compile and run in well under a minute on 2 cores
registry.register_bench_case("throw", ThrowBenchCase("segments", t_end_s=30.0, segment_length_m=5.0))
