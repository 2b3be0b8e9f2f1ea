"""Tiny Gymnasium environments for the command-line tests, registered when Gymnasium imports
this module (``line_env:LineWorld-v0``): a point on a line chasing a target drawn at reset, its
action Box [-2, 2] and a ``TimeLimit`` of 10 steps; ``LineWorld`` draws ``rgb_array`` frames
(the point and the target as columns of a 12 x 40 image), ``BlindLine`` draws none."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

WIDTH = 40


class LineWorld(gym.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, render_mode=None):
        self.render_mode = render_mode
        self.action_space = gym.spaces.Box(-2.0, 2.0, (1,), np.float32)
        self.observation_space = gym.spaces.Box(-5.0, 5.0, (2,), np.float32)

    def _obs(self):
        return np.array([self.x, self.target], np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x, self.target = 0.0, float(self.np_random.uniform(-1.0, 1.0))
        return self._obs(), {}

    def step(self, action):
        self.x = float(np.clip(self.x + float(action[0]), -5.0, 5.0))
        return self._obs(), -abs(self.x - self.target), False, False, {}

    def render(self):
        frame = np.full((12, WIDTH, 3), 255, np.uint8)
        for value, colour in ((self.target, (255, 0, 0)), (self.x, (0, 0, 255))):
            column = int(np.clip(round((value + 2.0) / 4.0 * (WIDTH - 1)), 0, WIDTH - 1))
            frame[:, column] = colour
        return frame


class BlindLine(LineWorld):
    metadata = {"render_modes": []}


for _name in ("LineWorld", "BlindLine"):
    if f"{_name}-v0" not in gym.registry:
        gym.register(f"{_name}-v0", entry_point=f"{__name__}:{_name}", max_episode_steps=10)
