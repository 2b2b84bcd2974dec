"""Sonar image front end: normalization, quality metrics, segmentation, matching, map
fusion and observation models. Submodules are imported explicitly (no eager imports)."""
