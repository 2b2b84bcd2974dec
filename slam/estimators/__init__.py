"""SLAM estimators behind one interface (see base.py): AEKF-SLAM, FastSLAM 2.0, iSAM2."""
