"""The beam sensor model (Probabilistic Robotics' mixture, as the MIT racecar's particle filter
uses it): how likely a beam reads r when the map says it should read d.

    p(r | d) = z_hit   N(r; d, sigma_hit)              the wall where the map has it, with the sensor's noise
             + z_short 2 (d - r) / d^2   for r < d    something nearer that the map lacks (a person, a cone)
             + z_max   [r = max]                       no return
             + z_rand  1 / max                         anything at all

precomputed once as a table over (measured, expected) ranges in map cells; each expected
column sums to 1. The filter adds log p over a scan's beams and multiplies the sum by
SOFTENING (the product of likelihoods raised to 1/2.2): neighbouring beams are not independent,
and a filter that treats them so grows overconfident.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SOFTENING = 1 / 2.2  # the power on the product of a scan's beam likelihoods


@dataclass(frozen=True)
class BeamModel:
    z_hit: float = 0.75
    z_short: float = 0.01
    z_max: float = 0.07
    z_rand: float = 0.12
    sigma_hit_m: float = 0.08  # [m] the hit's spread: the sensor's noise and the map's cells and errors

    def table(self, max_cells: int, resolution_m: float) -> np.ndarray:
        """(max_cells + 1, max_cells + 1) p[measured, expected], ranges in whole cells; the last
        row is the max reading."""
        r = np.arange(max_cells + 1, dtype=np.float64)[:, None]
        d = np.arange(max_cells + 1, dtype=np.float64)[None, :]
        sigma = self.sigma_hit_m / resolution_m
        hit = np.exp(-0.5 * ((r - d) / sigma) ** 2)
        hit /= hit.sum(axis=0, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            short = np.where((r < d) & (d > 0), 2 * (d - r) / np.maximum(d, 1) ** 2, 0.0)
        short_sum = short.sum(axis=0, keepdims=True)
        short = np.divide(short, short_sum, out=np.zeros_like(short), where=short_sum > 0)
        at_max = (r == max_cells).astype(np.float64)
        p = self.z_hit * hit + self.z_short * short + self.z_max * at_max + self.z_rand / (max_cells + 1)
        return p / p.sum(axis=0, keepdims=True)

    def log_table(self, max_cells: int, resolution_m: float) -> np.ndarray:
        """log of table(), softened: what the filter sums over a scan's beams."""
        return np.ascontiguousarray(SOFTENING * np.log(self.table(max_cells, resolution_m)))
