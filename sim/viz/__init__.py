"""Visualization: rerun logging (rerun_log.py is the only module that imports rerun) and figures."""
