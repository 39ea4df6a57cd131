"""The calibration report: HTML with the paper's tables and figures, rebuilt from the run store."""
