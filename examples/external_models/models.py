"""Two model classes the paper did not test, written as a user of crossaudit
would write them: in PyTorch, fitted on `crossaudit export`'s windows and
rolled out open loop from its starts.

- ``GRUModel``: a recurrent model. Its input at every step is the world
  standardized state and the raw action; it reads the ``history`` samples
  before each window (teacher forcing) and predicts the state-scaled
  increment of the last one. In a rollout its hidden state is first run
  over the start's history, then over its own predictions.
- ``ResidualModel``: a rigid-body quadrotor prior plus a learned residual.
  The prior accelerates the vehicle by thrust along its body z axis,
  k1 sum(u) + k2 sum(u^2), minus gravity and linear drag c v, with (k1, k2,
  c) fitted by least squares on the arm's fit windows; position moves with
  the new velocity, attitude is held. An MLP (three hidden layers of 256,
  as the paper's) learns what the prior misses, in the same state-scaled
  units.

Both predict dz = (x_{t+1} - x_t) / sd_x on the 10 non-exogenous state
components (position, velocity, quaternion); reference and battery are
overwritten with their measured values after every step, as crossaudit's
own rollouts do.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

GRAVITY = 9.81
DYNAMIC = list(range(10))  # p, v, q: what a model predicts
STATE, ACTION = 14, 4


class Standardizer:
    """The export's standardizers of one (model, arm): inputs and targets."""

    def __init__(self, std: dict):
        self.mean_in = torch.tensor(std["input"]["mean"], dtype=torch.float64)
        self.sd_in = torch.tensor(std["input"]["std"], dtype=torch.float64)
        self.mean_t = torch.tensor(std["target"]["mean"], dtype=torch.float64)
        self.sd_t = torch.tensor(std["target"]["std"], dtype=torch.float64)

    def inputs(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        raw = torch.cat([states, actions], dim=-1)
        return ((raw - self.mean_in) / self.sd_in).float()

    def targets(self, states: torch.Tensor, next_states: torch.Tensor) -> torch.Tensor:
        d = next_states - states
        d[..., 10:14] = 0.0
        return ((d - self.mean_t) / self.sd_t).float()

    def step(self, states: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        d = z.double() * self.sd_t + self.mean_t
        d[..., 10:14] = 0.0
        return states + d


class GRUModel(nn.Module):
    def __init__(self, hidden: int = 64):
        super().__init__()
        self.gru = nn.GRU(STATE + ACTION, hidden, batch_first=True)
        self.head = nn.Linear(hidden, STATE)

    def forward(self, seq: torch.Tensor, h: torch.Tensor | None = None):
        out, h = self.gru(seq, h)
        return self.head(out[:, -1]), h


class MLP(nn.Module):
    def __init__(self, width: int = 256):
        super().__init__()
        self.net = nn.Sequential(
            nn.Linear(STATE + ACTION, width),
            nn.ReLU(),
            nn.Linear(width, width),
            nn.ReLU(),
            nn.Linear(width, width),
            nn.ReLU(),
            nn.Linear(width, STATE),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


def body_z(q: torch.Tensor) -> torch.Tensor:
    """The body z axis in the world frame of unit quaternions (w, x, y, z)."""
    w, x, y, z = q.unbind(-1)
    return torch.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], dim=-1)


class RigidBody:
    """The quadrotor prior: dv/dt = (k1 sum u + k2 sum u^2) b_z - g e_z - c v."""

    def __init__(self, k1: float, k2: float, c: float, dt: float):
        self.k1, self.k2, self.c, self.dt = k1, k2, c, dt

    @staticmethod
    def fit(states: np.ndarray, actions: np.ndarray, next_states: np.ndarray, dt: float) -> "RigidBody":
        """Least squares of the measured acceleration on the three regressors."""
        v, v1 = states[:, 3:6], next_states[:, 3:6]
        a = (v1 - v) / dt + np.array([0.0, 0.0, GRAVITY])
        bz = body_z(torch.from_numpy(states[:, 6:10])).numpy()
        s1, s2 = actions.sum(1, keepdims=True), (actions**2).sum(1, keepdims=True)
        x = np.stack([(s1 * bz).ravel(), (s2 * bz).ravel(), -v.ravel()], axis=1)
        (k1, k2, c), *_ = np.linalg.lstsq(x, a.ravel(), rcond=None)
        return RigidBody(float(k1), float(k2), float(c), dt)

    def step(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        p, v, q = states[..., 0:3], states[..., 3:6], states[..., 6:10]
        thrust = self.k1 * actions.sum(-1, keepdim=True) + self.k2 * (actions**2).sum(-1, keepdim=True)
        g = torch.tensor([0.0, 0.0, GRAVITY], dtype=states.dtype)
        v1 = v + self.dt * (thrust * body_z(q) - g - self.c * v)
        out = states.clone()
        out[..., 0:3] = p + self.dt * v1
        out[..., 3:6] = v1
        return out


def finish_step(x: torch.Tensor, exogenous: torch.Tensor) -> torch.Tensor:
    """What crossaudit does after every step: measured reference and
    battery, unit quaternion."""
    x = x.clone()
    x[:, 10:14] = exogenous
    x[:, 6:10] = x[:, 6:10] / x[:, 6:10].norm(dim=1, keepdim=True)
    return x
