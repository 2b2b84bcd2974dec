"""Gymnasium environments of undersea. Importing this package registers them:

* ``undersea/WaypointNav-v0``  — reach waypoints from navigation sensors;
* ``undersea/SonarSurvey-v0``  — cover an area with the side-scan sonar;
* ``undersea/ActiveSLAM-v0``   — move so that sonar SLAM becomes certain and accurate.

    import gymnasium as gym
    import sim.envs  # noqa: F401  (registers the ids)
    env = gym.make("undersea/WaypointNav-v0", vehicle="alister9", render_mode="rgb_array")

    venv = gym.make_vec("undersea/WaypointNav-v0", num_envs=64,
                        vectorization_mode="vector_entry_point")  # sim.envs.vector_nav
    (SonarSurvey-v0 likewise: sim.envs.vector_sonar)

Each class docstring is the manual (spaces with units, rewards, episode end, arguments).
"""

from gymnasium.envs.registration import register, registry

_ENVS = {
    "undersea/WaypointNav-v0": ("sim.envs.waypoint_nav:WaypointNavEnv", 3000),
    "undersea/SonarSurvey-v0": ("sim.envs.sonar_survey:SonarSurveyEnv", 3000),
    "undersea/ActiveSLAM-v0": ("sim.envs.active_slam:ActiveSLAMEnv", 2000),
}
# batched versions (N vehicles in one MuJoCo model), for
# gymnasium.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")
_VECTOR = {
    "undersea/WaypointNav-v0": "sim.envs.vector_nav:WaypointNavVectorEnv",
    "undersea/SonarSurvey-v0": "sim.envs.vector_sonar:SonarSurveyVectorEnv",
}

for _id, (_entry, _steps) in _ENVS.items():
    if _id not in registry:
        register(
            id=_id,
            entry_point=_entry,
            vector_entry_point=_VECTOR.get(_id),
            max_episode_steps=_steps,
        )

ENV_IDS = tuple(_ENVS)
__all__ = ["ENV_IDS"]
