"""Input and output: measurement files by format, atomic writes."""
