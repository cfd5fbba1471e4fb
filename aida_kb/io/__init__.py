"""Files on disk: scene directories, evidence, models; atomic writes."""
