"""The papers' scenes with their nominal parameters."""

from .line_throwing import CALIBRATION, Launch, LineThrowingScene, line_throwing_scene, with_angle

__all__ = ["CALIBRATION", "Launch", "LineThrowingScene", "line_throwing_scene", "with_angle"]
