"""Domain errors of the pipeline: one base class, specific subclasses."""


class PipelineError(ValueError):
    """A measurement could not be made from the given data (a domain failure, not a bug)."""


class NoStripeError(PipelineError):
    """No usable laser stripe was found in a frame."""


class ArchiveError(PipelineError):
    """A pass archive or its manifest is malformed."""


class CalibrationError(PipelineError):
    """A calibration file or a calibration fit is invalid."""
