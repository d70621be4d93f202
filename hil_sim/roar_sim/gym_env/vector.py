"""Many Race-v0 environments stepped together on every core:

    envs = gymnasium.make_vec("roar_sim.gym_env:roar/Race-v0", num_envs=4, vectorization_mode="vector_entry_point")
    envs = RaceVectorEnv(4, workers=2, track="figure-eight")      # the same, directly

num_envs RaceEnvs, each in its own world, shared out over `workers` processes (default: one per
core, at most one per environment), this process among them: it steps its own share while the
others step theirs. Actions, observations, rewards and ends pass through shared memory; a step
costs each other process one short message each way (its environments' infos). Waking a process
blocked on a pipe is the dear part of a step on a virtual machine (~0.3 ms here, a third of a
step), so this process never waits idle for that: it is stepping its own share meanwhile.

Every environment is the very RaceEnv with its own seed (reset(seed=s) gives environment i the
seed s + i), so its observations, rewards and ends are those of a RaceEnv alone with that seed
and the same actions, bit for bit. Autoreset is Gymnasium's default (next step): the step after
an episode ends resets that environment (its action unused), with reward 0 and no end. With
autoreset_mode=AutoresetMode.SAME_STEP the step that ends an episode resets at once: it returns
the new episode's first observation, and the last one in info["final_obs"] (its info in
"final_info"), as Stable-Baselines3 and CleanRL expect (roar_sim.gym_env.sb3 adapts it to SB3).
step_each() and reset_each() give each environment's info dict in a list instead of Gymnasium's
merged arrays; call(), get_attr() and set_attr() reach every environment, wherever it runs.

The keywords are RaceEnv's (checked here, before any process starts: one ValueError),
`workers` and `autoreset_mode`. Ctrl-C or close() ends the other processes at once; one that
fails raises its error here (and everything is closed).
"""

from __future__ import annotations

import os
import pickle
import signal
import time
import traceback

import gymnasium as gym
import numpy as np
from gymnasium.vector.utils import batch_space
from gymnasium.vector.vector_env import AutoresetMode
from threadpoolctl import ThreadpoolController

from roar_sim.gym_env import RaceEnv
from roar_sim.runs.processes import cores, fork_context

SPIN_S = 0.005  # [s] a process waits this long awake (polling) before it sleeps on a pipe


def _await(pipe) -> None:
    """Until pipe has something to read: polling for up to SPIN_S, then asleep. A process that
    sleeps between steps (a virtual CPU halted, woken by an interrupt) wakes slowly and to cold
    caches: each step then cost a third more here than the same step in a process that ran on."""
    deadline = time.perf_counter() + SPIN_S
    while not pipe.poll() and time.perf_counter() < deadline:
        pass


def default_workers(num_envs: int) -> int:
    """One process per core this process may use, at most one per environment."""
    return max(1, min(num_envs, len(cores())))


class RaceVectorEnv(gym.vector.VectorEnv):
    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 2, workers: int | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, **env_kwargs) -> None:
        if not isinstance(num_envs, int) or isinstance(num_envs, bool) or not 1 <= num_envs <= 1024:
            raise ValueError(f"RaceVectorEnv: num_envs must be a whole number 1..1024, got {num_envs!r}")
        workers = default_workers(num_envs) if workers is None else workers
        if not isinstance(workers, int) or isinstance(workers, bool) or not 1 <= workers <= num_envs:
            raise ValueError(f"RaceVectorEnv: workers (processes stepping environments, this one among them) "
                             f"must be a whole number 1..num_envs ({num_envs}), got {workers!r}")
        if env_kwargs.get("render_mode") is not None:
            raise ValueError("RaceVectorEnv: render_mode is for one environment (gymnasium.make)")
        modes = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)
        try:
            autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            autoreset_mode = None
        if autoreset_mode not in modes:
            raise ValueError(f"RaceVectorEnv: autoreset_mode must be one of {', '.join(m.value for m in modes)}")
        self.metadata = {**self.metadata, "autoreset_mode": autoreset_mode}
        probe = RaceEnv(**env_kwargs)  # checks every keyword; builds no world (reset() does)
        self.num_envs = num_envs
        self.single_observation_space = probe.observation_space
        self.single_action_space = probe.action_space
        self.observation_space = batch_space(probe.observation_space, num_envs)
        self.action_space = batch_space(probe.action_space, num_envs)
        self.env_kwargs = env_kwargs
        self._closed = True
        context = fork_context()
        # the shared memory: one array per observation key, actions, rewards, ends
        layout = {f"obs:{k}": (space.shape, space.dtype) for k, space in probe.observation_space.spaces.items()}
        layout.update({"action": ((2,), np.dtype(np.float32)), "reward": ((), np.dtype(np.float64)),
                       "terminated": ((), np.dtype(np.bool_)), "truncated": ((), np.dtype(np.bool_))})
        self._raw = {name: (context.RawArray("b", max(1, num_envs * int(np.prod(shape)) * dtype.itemsize)), shape, dtype)
                     for name, (shape, dtype) in layout.items()}
        self._arrays = _views(self._raw, num_envs)
        shares = np.array_split(np.arange(num_envs), workers)
        self._pipes, self._processes = [], []
        self._counts = [len(share) for share in shares]  # environments per process, this one first
        same_step = autoreset_mode == AutoresetMode.SAME_STEP
        self._own = _Share(int(shares[0][0]), len(shares[0]), env_kwargs, self._arrays, same_step)
        available = cores()
        for k, share in enumerate(shares[1:], start=1):
            ours, theirs = context.Pipe()
            core = available[k % len(available)]  # each other process on a core of its own (this one: the rest)
            process = context.Process(target=_work, args=(theirs, int(share[0]), len(share), env_kwargs, same_step,
                                                          self._raw, num_envs, core), daemon=True, name="roar-race-env")
            process.start()
            theirs.close()
            self._pipes.append(ours)
            self._processes.append(process)
        self._closed = False

    # --- gymnasium ---------------------------------------------------------------------------

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        observation, infos = self.reset_each(seed=seed, options=options)
        return observation, self._merged(infos)

    def step(self, actions):
        observation, rewards, terminated, truncated, infos = self.step_each(actions)
        return observation, rewards, terminated, truncated, self._merged(infos)

    def call(self, name: str, *args, **kwargs) -> tuple:
        """Each environment's method name called with args (or its attribute name, if not callable)."""
        return tuple(self._each(("call", name, args, kwargs), lambda share: share.call(name, args, kwargs)))

    def get_attr(self, name: str) -> tuple:
        return self.call(name)

    def set_attr(self, name: str, values) -> None:
        """Each environment's attribute name set: to values[i], or to values for all if not a list or tuple."""
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(f"set_attr: {len(values)} values for {self.num_envs} environments")
        self._scatter("set", values, name)
        self._each(None, lambda share: share.set(values[:self._counts[0]], name))

    # --- each environment's info, in a list --------------------------------------------------

    def reset_each(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """reset(), with each environment's info dict in a list."""
        if seed is None or isinstance(seed, int):
            seeds = [None if seed is None else seed + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"reset: {len(seeds)} seeds for {self.num_envs} environments")
        self._scatter("reset", seeds, options)
        infos = self._each(None, lambda share: share.reset(seeds[:self._counts[0]], options))  # all written now
        return self._observation(), infos

    def step_each(self, actions):
        """step(), with each environment's info dict in a list."""
        try:
            actions = np.asarray(actions, np.float64).reshape(self.num_envs, 2)
        except (TypeError, ValueError):
            actions = None
        if actions is None or not np.isfinite(actions).all():  # (as RaceEnv, before any environment moves)
            raise ValueError(f"actions are {self.num_envs} x (throttle, steering), finite numbers (each clipped "
                             f"to -1..1)")
        np.copyto(self._arrays["action"], actions.astype(np.float32))
        try:
            for pipe in self._pipes:
                pipe.send_bytes(b"s")
        except OSError:
            self._died()
        infos = self._each(None, _Share.step)  # ours while they step theirs
        a = self._arrays
        return self._observation(), a["reward"].copy(), a["terminated"].copy(), a["truncated"].copy(), infos

    def close_extras(self, **kwargs) -> None:
        if self._closed:
            return
        self._closed = True
        for pipe in self._pipes:
            try:
                pipe.send(("close",))
            except (BrokenPipeError, OSError):
                pass
        for process in self._processes:
            process.join(timeout=5)
            if process.is_alive():
                process.kill()
        for pipe in self._pipes:
            pipe.close()
        self._own.close()

    def __del__(self):
        if not getattr(self, "_closed", True):
            self.close()

    # --- helpers -----------------------------------------------------------------------------

    def _send(self, pipe, command) -> None:
        try:
            pipe.send(command)
        except OSError:
            self._died()

    def _scatter(self, verb: str, values: list, *rest) -> None:
        """To each other process, (verb, its environments' part of values, *rest)."""
        at = self._counts[0]
        for pipe, n in zip(self._pipes, self._counts[1:]):
            self._send(pipe, (verb, list(values[at:at + n]), *rest))
            at += n

    def _each(self, command, own) -> list:
        """command sent to the other processes (None: already sent), own(our share) done here
        meanwhile, then every environment's answer in order. If our share fails, the others'
        answers would be left unread in the pipes (and taken for the next call's): everything is
        closed before the error goes on."""
        if command is not None:
            for pipe in self._pipes:
                self._send(pipe, command)
        try:
            answers = list(own(self._own))
        except BaseException:
            self.close()
            raise
        for pipe in self._pipes:
            try:
                _await(pipe)
                answer = pipe.recv()
            except (EOFError, OSError):
                self._died()
            if isinstance(answer, str):  # a worker's error, its traceback
                self.close()
                raise RuntimeError(f"a RaceVectorEnv environment failed:\n{answer}")
            answers.extend(answer)
        return answers

    def _died(self):
        self.close()
        raise RuntimeError("a RaceVectorEnv worker died (killed, or out of memory)") from None

    def _observation(self) -> dict:
        return {key[4:]: array.copy() for key, array in self._arrays.items() if key.startswith("obs:")}

    def _merged(self, each: list[dict]) -> dict:
        """Every environment's info merged as Gymnasium's vector infos are."""
        infos = {}
        for i, info in enumerate(each):
            infos = self._add_info(infos, info, i)
        return infos


def _views(raw: dict, num_envs: int) -> dict[str, np.ndarray]:
    return {name: np.frombuffer(buffer, dtype, num_envs * int(np.prod(shape))).reshape((num_envs, *shape))
            for name, (buffer, shape, dtype) in raw.items()}


class _Share:
    """Environments first..first+count-1, stepped in turn (in this process or another)."""

    def __init__(self, first: int, count: int, env_kwargs: dict, arrays: dict[str, np.ndarray],
                 same_step: bool) -> None:
        self.rows = range(first, first + count)
        self.same_step = same_step
        self.arrays = arrays
        self.observations = {key[4:]: array for key, array in arrays.items() if key.startswith("obs:")}
        self.envs = [RaceEnv(**env_kwargs) for _ in self.rows]
        self.ended = [False] * count

    def _put(self, i: int, observation: dict) -> None:
        for key, value in observation.items():
            self.observations[key][i] = value

    def step(self) -> list[dict]:
        a, infos = self.arrays, []
        for j, (i, env) in enumerate(zip(self.rows, self.envs)):
            if self.ended[j]:  # next-step autoreset
                observation, info = env.reset()
                reward, terminated, truncated = 0.0, False, False
            else:
                observation, reward, terminated, truncated, info = env.step(a["action"][i])
                if self.same_step and (terminated or truncated):
                    final = {"final_obs": observation, "final_info": info}
                    observation, info = env.reset()
                    info = {**info, **final}
            self.ended[j] = not self.same_step and (terminated or truncated)
            self._put(i, observation)
            a["reward"][i], a["terminated"][i], a["truncated"][i] = reward, terminated, truncated
            infos.append(info)
        return infos

    def reset(self, seeds, options) -> list[dict]:
        infos = []
        for j, (i, env, seed) in enumerate(zip(self.rows, self.envs, seeds)):
            observation, info = env.reset(seed=seed, options=options)
            self.ended[j] = False
            self._put(i, observation)
            infos.append(info)
        return infos

    def call(self, name: str, args: tuple, kwargs: dict) -> list:
        results = []
        for env in self.envs:
            value = env.get_wrapper_attr(name)
            results.append(value(*args, **kwargs) if callable(value) else value)
        return results

    def set(self, values: list, name: str) -> list:
        for env, value in zip(self.envs, values):
            env.set_wrapper_attr(name, value)
        return []

    def close(self) -> None:
        for env in self.envs:
            env.close()


def _work(pipe, first: int, count: int, env_kwargs: dict, same_step: bool, raw: dict, num_envs: int,
          core: int) -> None:
    """Another process: its share, stepped on this process's word, on its own core, with one BLAS
    thread (OpenBLAS's idle threads spin, taking the core another process steps on)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the main process's to handle: it closes us
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {core})
    ThreadpoolController().limit(limits=1, user_api="blas")  # for the life of this process
    share = _Share(first, count, env_kwargs, _views(raw, num_envs), same_step)
    try:
        while True:
            _await(pipe)
            message = pipe.recv_bytes()
            if message == b"s":
                pipe.send(share.step())
                continue
            command = pickle.loads(message)
            if command[0] == "close":
                break
            pipe.send(getattr(share, command[0])(*command[1:]))  # reset, call, set
    except (EOFError, BrokenPipeError, KeyboardInterrupt):
        pass
    except Exception:  # the main process raises it
        try:
            pipe.send(traceback.format_exc())
        except (BrokenPipeError, OSError):
            pass
    finally:
        share.close()
