"""Version of the numerical pipeline. Bump on any change to numerical output."""

PIPELINE_VERSION = "0.12.9"
