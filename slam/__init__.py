"""undersea SLAM side: sonar image front end, observation models, AEKF-SLAM and baselines,
metrics. Works on numpy arrays and plain dataclasses; never imports ``sim`` or mujoco.
"""
