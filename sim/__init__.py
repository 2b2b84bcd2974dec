"""undersea simulator side: MuJoCo world, vehicles, hydrodynamics, nav sensors, sonars,
missions, gymnasium environments, scenario runner and the ``undersea`` CLI.

May import ``slam`` only from the runner, the environments and the CLI.
"""
