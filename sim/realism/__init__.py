"""Simulated surveys for realism calibration (``undersea calibrate``): the ray-cast side-scan
sonar flown over a flat seabed at a recording's altitude and range. Imports no ``slam``;
the statistics and the fit (``slam.realism``) are joined to it in ``sim.cli``."""
