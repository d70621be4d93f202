"""Race-v0 environments on every core for Stable-Baselines3 (which has its own VecEnv API):

    from stable_baselines3 import PPO
    from roar_sim.gym_env.sb3 import RaceVecEnv
    envs = RaceVecEnv(4, track="oval", lidar_beams=36)   # RaceVectorEnv's keywords: workers, RaceEnv's
    envs = RaceVecEnv(1024, batched=True, track="oval")  # the batched world's cars (BatchRaceEnv's keywords)
    PPO("MultiInputPolicy", envs, seed=0).learn(100_000)

RaceVectorEnv (roar_sim.gym_env.vector) with same-step autoreset under SB3's names: an ended
episode's last observation is info["terminal_observation"], a time limit is
info["TimeLimit.truncated"], as SB3's own vector environments give them. seed(s) then reset() gives
environment i the seed s + i, as RaceVectorEnv and SB3 do, so the same seeds give the same
training whatever the number of processes. Needs stable-baselines3: pip install 'roar-platform[rl]'.
"""

from __future__ import annotations

import numpy as np
from gymnasium.vector.vector_env import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from roar_sim.gym_env.vector import RaceVectorEnv


class RaceVecEnv(VecEnv):
    def __init__(self, num_envs: int = 2, batched: bool = False, **kwargs) -> None:
        """batched=True: the batched world's cars (roar_sim.gym_env.batched.BatchRaceEnv, its
        keywords), thousands at a time in this process; otherwise RaceVectorEnv's."""
        if batched:
            from roar_sim.gym_env.batched import BatchRaceEnv

            self.vector = BatchRaceEnv(num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
        else:
            self.vector = RaceVectorEnv(num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
        super().__init__(num_envs, self.vector.single_observation_space, self.vector.single_action_space)
        self._actions = None

    def reset(self):
        if any(options != self._options[0] for options in self._options):
            raise ValueError("RaceVecEnv: every environment takes the same reset options")
        observation, infos = self.vector.reset_each(seed=list(self._seeds), options=self._options[0] or None)
        self.reset_infos = infos
        self._reset_seeds()
        self._reset_options()
        return observation

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        observation, rewards, terminated, truncated, infos = self.vector.step_each(self._actions)
        dones = terminated | truncated
        for i in np.flatnonzero(dones):
            info = infos[i]
            self.reset_infos[i] = {k: v for k, v in info.items() if k not in ("final_obs", "final_info")}
            infos[i] = {**info.pop("final_info"), "terminal_observation": info.pop("final_obs"),
                        "TimeLimit.truncated": bool(truncated[i] and not terminated[i])}
        for i in np.flatnonzero(~dones):
            infos[i]["TimeLimit.truncated"] = False
        return observation, rewards, dones, infos  # float64, as SubprocVecEnv gives them

    def close(self) -> None:
        self.vector.close()

    def get_attr(self, attr_name: str, indices=None) -> list:
        values = self.vector.get_attr(attr_name)
        return [values[i] for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value, indices=None) -> None:
        values = list(self.vector.get_attr(attr_name))
        for i in self._get_indices(indices):
            values[i] = value
        self.vector.set_attr(attr_name, values)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        if list(self._get_indices(indices)) != list(range(self.num_envs)):
            raise ValueError("RaceVecEnv.env_method calls every environment's method (indices=None)")
        return list(self.vector.call(method_name, *method_args, **method_kwargs))

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]  # RaceEnvs, unwrapped
