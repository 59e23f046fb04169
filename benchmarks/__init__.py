"""Speed and accuracy benchmarks; `python -m benchmarks.run` (make bench) writes BENCHMARKS.md."""
