"""tdicam: dataflow model and co-simulation harness of a digital-TDI push-broom camera."""

from tdicam.errors import TdicamError

__all__ = ["TdicamError"]
__version__ = "0.1.0"
