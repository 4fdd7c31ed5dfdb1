"""The design-matrix view: named terms, per-axis design matrices, weighted least squares.

Every accelerometer model here is linear in its parameters once the nominal
specific force, the temperature and the time of each step are known:

    a_j = sum_i p_ji * column_i(f, T, t)          for output axis j

A :class:`Term` is one named column with its unit; a :class:`LinearModel`
lists the terms that enter each output axis. The seed's triangular model,
the 12-parameter model, the thermal bias polynomial and any term the
discrepancy workflow adds are all just term lists; one solver serves them.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from calib.numerics.special import chi2_sf

from calib.errors import ObservabilityError
from calib.frames import SENSOR_AXES

if TYPE_CHECKING:  # type hints only: calib.accel imports this module
    from calib.accel.inputs import StepMeans



@dataclass(frozen=True)
class Inputs:
    """What the columns are functions of (one row per step)."""

    f_g: np.ndarray  # (K, 3) nominal specific force, g
    temp_c: np.ndarray | None  # (K,)
    t_s: np.ndarray  # (K,)
    t0_c: float = 25.0

    @classmethod
    def from_steps(cls, steps: StepMeans, t0_c: float | None = None) -> "Inputs":
        t0 = t0_c if t0_c is not None else (float(np.mean(steps.temp_c)) if steps.temp_c is not None else 25.0)
        return cls(np.asarray(steps.f_nominal_g, float), steps.temp_c, np.asarray(steps.t_s, float), t0)


@dataclass(frozen=True)
class Term:
    """One named column of a design matrix.

    Attributes
    ----------
    name : parameter name (e.g. ``b_x``, ``k_x``, ``m_xy``, ``c1_x``).
    unit : unit of the parameter (counts, counts/g, counts/C, ...).
    column : function of :class:`Inputs` -> (K,) column.
    needs : which inputs it needs ("temp", "time"), for observability messages.
    hint : what coverage determines it, for observability messages.
    """

    name: str
    unit: str
    column: Callable[[Inputs], np.ndarray]
    needs: tuple[str, ...] = ()
    hint: str = ""


def const_term(axis: str) -> Term:
    return Term(f"b_{axis}", "counts", lambda x: np.ones(len(x.f_g)), hint="any pose")


def force_term(name: str, component: int) -> Term:
    ax = SENSOR_AXES[component]
    return Term(name, "counts/g", lambda x, c=component: x.f_g[:, c],
                hint=f"poses with gravity along +{ax.upper()} and -{ax.upper()}")


def temp_term(axis: str, order: int) -> Term:
    return Term(f"c{order}_{axis}", f"counts/C^{order}" if order > 1 else "counts/C",
                lambda x, s=order: (x.temp_c - x.t0_c) ** s, needs=("temp",),
                hint="steps at several temperatures")


@dataclass
class LinearModel:
    """Terms per output axis (x, y, z)."""

    terms: dict[str, list[Term]] = field(default_factory=dict)

    def with_terms(self, axis: str, extra: list[Term]) -> "LinearModel":
        t = {a: list(v) for a, v in self.terms.items()}
        t[axis] = t.get(axis, []) + list(extra)
        return LinearModel(t)

    def design(self, axis: str, x: Inputs) -> np.ndarray:
        cols = [np.asarray(term.column(x), float) for term in self.terms[axis]]
        return np.stack(cols, axis=1)

    def names(self, axis: str) -> list[str]:
        return [t.name for t in self.terms[axis]]


@dataclass
class AxisFit:
    """Weighted least-squares result for one output axis."""

    names: list[str]
    params: np.ndarray  # (P,)
    cov: np.ndarray  # (P, P), 1-sigma^2, after the misfit rule
    cov_noise: np.ndarray  # (P, P) from the within-step scatter alone
    residuals: np.ndarray  # (K,) counts
    chi2: float
    dof: int
    inflated: bool  # misfit significant (the covariance is not rescaled)


DISPLAY_NAMES = {"kx_ayz": "alpha_yz", "kx_azy": "alpha_zy", "ky_azx": "alpha_zx"}


def undetermined(g: np.ndarray, names: list[str], cond_max: float = 1e10) -> list[str]:
    """Parameters of one axis' design that the rows do not determine (empty when all are)."""
    k, p = g.shape
    if k < p:
        return list(names) if k == 0 else _null_names(np.vstack([g, np.zeros((p - k, p))]), names, cond_max)
    return _null_names(g, names, cond_max)


def _null_names(g, names, cond_max):
    scale = np.linalg.norm(g, axis=0)
    scale[scale == 0] = 1.0
    _, sv, vt = np.linalg.svd(g / scale, full_matrices=False)  # the (K, K) left factor is never used: 30,000^2 at 10,000 steps
    small = sv < sv[0] * (1.0 / cond_max) if sv[0] > 0 else np.ones_like(sv, bool)
    if not small.any():
        return []
    null = vt[small]
    return [n for n, v in zip(names, np.abs(null).max(axis=0)) if v > 1e-6]


def check_rank(g: np.ndarray, names: list[str], terms: list[Term], axis: str, cond_max: float = 1e10) -> None:
    """Raise ObservabilityError naming the parameters one axis' design leaves undetermined."""
    check_model({axis: (g, names, terms)}, cond_max)


def check_model(designs: dict, cond_max: float = 1e10) -> None:
    """designs: axis -> (G, names, terms). One error naming every undetermined parameter."""
    bad, hints, counts = [], [], []
    for axis, (g, names, terms) in designs.items():
        miss = undetermined(g, names, cond_max)
        if miss:
            bad += miss
            hints += [t.hint for t in terms if t.name in miss and t.hint and t.hint not in hints]
            counts.append(f"axis {axis}: {g.shape[0]} steps, {g.shape[1]} parameters")
    if bad:
        shown = ", ".join(DISPLAY_NAMES.get(n, n) for n in bad)
        raise ObservabilityError(f"the pose set leaves {shown} undetermined ({'; '.join(counts)}"
                                 + (f"; needs {'; '.join(hints)}" if hints else "") + ")")


#: the one misfit level: a weighted fit whose chi-square lies beyond this upper quantile misses something the
#: noise does not explain. The solvers rescale their sigmas by it (Birge ratio), ``rig solve`` and the report
#: say so by it, and it is the discovery's default false-alarm rate.
MISFIT_LEVEL = 0.01


def misfit(chi2: float, dof: int, level: float = MISFIT_LEVEL) -> tuple[bool, float]:
    """Whether a weighted fit's chi-square is beyond its upper ``level`` quantile on ``dof`` (the model
    misses something the noise does not explain), and its upper-tail probability (1 when dof <= 0).

    The one rule behind the Birge-ratio rescaling of the solvers and the discovery verdict.
    """
    if dof <= 0:
        return False, 1.0
    p = float(chi2_sf(chi2, dof))
    return p < level, p


def session_rule(fits, level: float = MISFIT_LEVEL):
    """The per-axis fits of one session with the Birge rescale decided on the whole session.

    Each axis's fit rescales its covariance when its own misfit is significant at ``level``; over
    three axes that happens to a clean session 3 % of the time, and such a session reports sigmas
    inflated by its chance chi2/dof (issue 14: "each session's sigma within 25 %"). Here a rescale
    stands only when the session's summed chi2 on its summed dof is itself significant at ``level``
    (and the axis's own misfit is): a clean session is rescaled at most ``level`` of the time, a
    session whose model misses something on one axis still is on that axis.

    ``fits``: a dict or a sequence of :class:`AxisFit`; returned as the same kind.
    """
    items = list(fits.items()) if isinstance(fits, dict) else list(enumerate(fits))
    chi2 = sum(f.chi2 for _, f in items)
    dof = sum(f.dof for _, f in items)
    if misfit(chi2, dof, level)[0]:
        return fits
    kept = [(k, dataclasses.replace(f, cov=f.cov_noise, inflated=False)) for k, f in items]
    return dict(kept) if isinstance(fits, dict) else type(fits)(f for _, f in kept)


def solve_wls(g: np.ndarray, y: np.ndarray, sem: np.ndarray, names: list[str],
              misfit_p: float = MISFIT_LEVEL) -> AxisFit:
    """Weighted least squares with 1/sem^2 weights.

    Covariance: ``(G^T W G)^-1``, the per-step standard errors propagated. It is rescaled by the
    fit's chi2/dof (the Birge ratio) only when the misfit is significant at level ``misfit_p``
    (``inflated``): then the model misses something and the scatter of the steps about it, not the
    noise, sets the uncertainty (hand-placed poses, an unmodelled effect). A clean session's chi2/dof
    scatters widely with a handful of degrees of freedom; rescaling by it regardless made identical
    sessions report sigmas a factor of 5 apart, so an insignificant misfit leaves the sigmas alone.
    """
    w = 1.0 / sem
    return solve_whitened(g, y, g * w[:, None], y * w, names, misfit_p)


def solve_whitened(g: np.ndarray, y: np.ndarray, gw: np.ndarray, yw: np.ndarray, names: list[str],
                   misfit_p: float = MISFIT_LEVEL) -> AxisFit:
    """Least squares on the whitened design ``gw`` and data ``yw`` (weighted: rows divided by the
    sem; generalised: premultiplied by the inverse Cholesky factor of the data's covariance), with
    the Birge rescale of :func:`solve_wls`; residuals are ``y - g p`` in the data's own units."""
    q, r = np.linalg.qr(gw)
    params = np.linalg.solve(r, q.T @ yw)
    rinv = np.linalg.inv(r)
    cov0 = rinv @ rinv.T
    white = yw - gw @ params
    chi2 = float(white @ white)
    dof = g.shape[0] - g.shape[1]
    inflated, _ = misfit(chi2, dof, misfit_p)
    cov = cov0 * (chi2 / dof) if inflated else cov0
    return AxisFit(list(names), params, cov, cov0, y - g @ params, chi2, dof, inflated)


def solve_gls(g: np.ndarray, y: np.ndarray, cov_y: np.ndarray, names: list[str],
              misfit_p: float = MISFIT_LEVEL) -> AxisFit:
    """Generalised least squares with the data's covariance ``cov_y`` (K, K) (the step means' standard
    errors on the diagonal plus the sensor's bias wander between the steps, :mod:`calib.numerics.wander`):
    whitened by its Cholesky factor, then as :func:`solve_wls` (rescaled by chi2/dof only when the
    misfit is significant at ``misfit_p``). Residuals are in the data's own units (not whitened).
    Shared by the accelerometer, gyroscope and magnetometer solvers."""
    chol = np.linalg.cholesky(cov_y)
    return solve_whitened(g, y, np.linalg.solve(chol, g), np.linalg.solve(chol, y), names, misfit_p)
