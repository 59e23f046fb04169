"""wheelscan pipeline: pure image → measurement functions (NumPy, SciPy, OpenCV only)."""

from pipeline.archive.pass_archive import PassArchive, read_pass_archive, write_pass_archive
from pipeline.calibration.model import (
    StationCalibration,
    load_calibration_json,
    read_calibration,
    write_calibration,
)
from pipeline.errors import ArchiveError, CalibrationError, NoStripeError, PipelineError
from pipeline.extraction.centres import Centres, extract_centres
from pipeline.profile.measurement import (
    WheelMeasurement,
    axle_back_to_back,
    measure_pass,
    measure_wheel,
)
from pipeline.version import PIPELINE_VERSION

__all__ = [
    "PIPELINE_VERSION",
    "ArchiveError",
    "CalibrationError",
    "Centres",
    "NoStripeError",
    "PassArchive",
    "PipelineError",
    "StationCalibration",
    "WheelMeasurement",
    "axle_back_to_back",
    "extract_centres",
    "load_calibration_json",
    "measure_pass",
    "measure_wheel",
    "read_calibration",
    "read_pass_archive",
    "write_calibration",
    "write_pass_archive",
]
