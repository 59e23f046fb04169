"""wheelscan pipeline: pure image → measurement functions (NumPy, SciPy, OpenCV only)."""

from pipeline.centres import Centres, extract_centres
from pipeline.errors import ArchiveError, CalibrationError, NoStripeError, PipelineError
from pipeline.version import PIPELINE_VERSION

__all__ = [
    "PIPELINE_VERSION",
    "ArchiveError",
    "CalibrationError",
    "Centres",
    "NoStripeError",
    "PipelineError",
    "extract_centres",
]
