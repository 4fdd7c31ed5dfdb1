"""The linear problem of the discrepancy search: generalised least squares over all steps and axes.

The step means of a session are not independent: besides each mean's own standard error
(``sem``, from the scatter of the step's samples) they share the slow wander of the bias
(:mod:`calib.numerics.wander`). The covariance of the stacked means (axis-major rows, counts^2) is

    V = blockdiag_j( diag(sem_j^2) + lsb^2 W ),   W = wander_cov_g2(step times, durations, bias stability)

and every fit is ordinary least squares after whitening by the Cholesky factor of V
(``L^-1 y = L^-1 G theta + e``, e ~ N(0, I) when the model holds). The whitened residual of
step i is its *innovation*: its residual less what the residuals of the steps before it
predict through the wander, in standard deviations. Chi-square, the nested tests and the
verdict all use it, so they are calibrated when the wander is there, and reduce to the
familiar ``r / sem`` weighting when the stability is unknown (``StepMeans.bias_stability`` None).

A nested model is judged by the chi-square drop per added column against the larger of the
stated noise (1, whitened) and the residual mean square the bigger model leaves
(:func:`nested_test`): referred to its exact distribution with V right while the bigger model fits,
to the F distribution once it does not. With V right it is nearly as sensitive as the chi-square
test with V known, and not erratic when few dof are left (an F test alone on a six-position
session's 7 dof turns a residual mean square of 0.1 and a chance drop of 5 into an effect); when the
bigger model leaves more scatter than the noise explains (an open gap) it is the F test.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import linalg, special, stats

from calib.accel.inputs import StepMeans
from calib.numerics.design import MISFIT_LEVEL, misfit
from calib.discovery.effects import LIBRARY, EffectInputs
from calib.frames import SENSOR_AXES
from calib.numerics.magnitude import fit_magnitude
from calib.numerics.wander import wander_cov_g2

#: baseline columns: which force components enter each output axis (the seed's triangular model)
TRIANGULAR_COLUMNS = {"x": [0, 1, 2], "y": [1, 2], "z": [2]}
MIN_JUMP_SIDE = 3  # steps a bias jump needs on each side
FLOOR_GRID = 200  # conditional quantiles of the residual chi-square averaged over in floored_sf
SCATTER_LEVEL = MISFIT_LEVEL  # a bigger model whose chi-square is beyond this upper quantile leaves more than the noise
COLUMN_TOL = 1e-6  # a whitened column whose part outside the model is below this fraction is dependent
#: per-step nuisance columns an effect brings with it: thermal_hysteresis leaves the steps before the
#: first known heating or cooling transition (leg unknown, h = 0) to an offset of their own
NUISANCE = {"thermal_hysteresis": "initial_leg"}


@dataclass
class Fit:
    theta: np.ndarray
    cov0: np.ndarray
    rss: float  # generalised chi-square (whitened)
    dof: int
    resid: np.ndarray  # (3K,) counts
    names: list  # (block, index) per column
    white: np.ndarray  # whitened residual rows


class Problem:
    """Stacked generalised least squares over all steps and output axes (axis-major rows)."""

    def __init__(self, steps: StepMeans, ctx, t0_c: float, t_ref_s: float) -> None:
        self.steps = steps
        self.ctx = ctx
        self.k = len(steps)
        self.lsb = float(steps.lsb_per_g)
        self.y = np.asarray(steps.mean_counts, float).T.ravel()
        self.sem = np.asarray(steps.sem_counts, float).T.ravel()
        f = np.asarray(steps.f_nominal_g, float)
        self.pose_free = not np.all(np.isfinite(f))
        self.f = np.where(np.isfinite(f), f, 0.0)
        self.t0_c = t0_c
        self.t_ref_s = t_ref_s
        self.wander_g2 = wander_cov_g2(np.asarray(steps.t_s, float), steps.duration_s, steps.bias_stability)
        self.base, self.base_names = self._baseline()
        self.matrix_g = np.eye(3)
        self.cols: dict[str, np.ndarray] = {}
        self.keep: dict[str, np.ndarray] = {}
        self.labels: dict[str, tuple] = {}  # each effect's parameters in this session
        self.jump_grid = jump_times(np.asarray(steps.t_s, float))
        self.t_jump = float(np.median(self.jump_grid)) if len(self.jump_grid) else None
        self.multiplicity = {"bias_jump": max(len(self.jump_grid), 1)}  # Bonferroni cost of the time search
        cov = getattr(ctx, "rig_cov_counts2", None)
        self.rig_cov = (np.asarray(cov, float) if cov is not None and not self.pose_free
                        and np.shape(cov) == (3 * self.k, 3 * self.k) and np.any(cov) else None)
        self._full = None  # L^-1 of the whole (3K, 3K) V when the rig's errors couple the axes
        self._factors = self._cholesky()
        self._white: dict[str, np.ndarray] = {}

    # -- covariance ------------------------------------------------------------------------------
    def _cholesky(self) -> list:
        """Inverses of the lower Cholesky factors of each block of V (None for a diagonal block: divide by sem);
        with the rig's errors (``rig_cov``: they move a pose's force on two axes at once, and every pose a stage
        error reaches) the inverse factor of the whole V instead (``_full``)."""
        w = self.wander_g2 * self.lsb**2
        if getattr(self, "rig_cov", None) is not None:
            blocks = np.zeros((3 * self.k, 3 * self.k))
            for j in range(3):
                blocks[j * self.k:(j + 1) * self.k, j * self.k:(j + 1) * self.k] = \
                    np.diag(self.sem[j * self.k:(j + 1) * self.k] ** 2) + w
            self._full = _inverse_cholesky(blocks + self.rig_cov)
            return [None] * 3
        if not np.any(self.wander_g2):
            return [None] * 3
        return [_inverse_cholesky(np.diag(self.sem[j * self.k:(j + 1) * self.k] ** 2) + w) for j in range(3)]

    def whiten(self, m: np.ndarray) -> np.ndarray:
        """L^-1 m for fit rows ``m`` (3K,) or (3K, P)."""
        if self._full is not None:
            return self._full @ m
        k = self.k
        out = np.empty_like(m, dtype=float)
        for j, inv in enumerate(self._factors):
            blk = m[j * k:(j + 1) * k]
            s = self.sem[j * k:(j + 1) * k].reshape((k,) + (1,) * (m.ndim - 1))
            out[j * k:(j + 1) * k] = blk / s if inv is None else inv @ blk
        return out

    def white_cols(self, name: str) -> np.ndarray:
        """Whitened fit rows of effect ``name``'s columns (cached until its columns are rebuilt)."""
        if name not in self._white:
            self._white[name] = self.whiten(self.rows(self.cols[name]))
        return self._white[name]

    def rows(self, m: np.ndarray) -> np.ndarray:
        """Stacked (3K, ...) axis-major rows -> the rows the fit uses (here: the same)."""
        return m

    def spread(self, rows: np.ndarray) -> np.ndarray:
        """Fit-row residuals -> (3K,) axis-major residuals (here: the same)."""
        return rows

    # -- design ----------------------------------------------------------------------------------
    def _baseline(self):
        k = self.k
        blocks, names = [], []
        for j, a in enumerate(SENSOR_AXES):
            if self.pose_free:
                groups = np.unique(self.ctx.pose_group) if self.ctx.pose_group is not None else np.array([0])
                labels = self.ctx.pose_group if self.ctx.pose_group is not None else np.zeros(k, int)
                cols = [(labels == g).astype(float) for g in groups]
                nm = [f"b_{a}[{g}]" for g in groups]
            else:
                cols = [np.ones(k)] + [self.f[:, c] for c in TRIANGULAR_COLUMNS[a]]
                nm = [f"b_{a}"] + [f"m_{a}{SENSOR_AXES[c]}" for c in TRIANGULAR_COLUMNS[a]]
            for c, n in zip(cols, nm):
                full = np.zeros(3 * k)
                full[j * k:(j + 1) * k] = c
                blocks.append(full)
                names.append(n)
        return np.stack(blocks, axis=1), names

    def inputs(self) -> EffectInputs:
        s = self.steps
        return EffectInputs(f_g=self.f, temp_c=None if s.temp_c is None else np.asarray(s.temp_c, float),
                            t_s=np.asarray(s.t_s, float), heating=self.ctx.heating,
                            base_to_sensor=self.ctx.base_to_sensor, matrix_g=self.matrix_g, t0_c=self.t0_c,
                            t_ref_s=self.t_ref_s, temp_rate=self.ctx.temp_rate, t_jump_s=self.t_jump,
                            pose_block=None if self.pose_free else pose_blocks(self.f, np.asarray(s.t_s, float)))

    def set_jump(self, t_jump_s: float) -> None:
        """Move the bias jump to ``t_jump_s`` (rebuilds its columns)."""
        self.t_jump = float(t_jump_s)
        self.build_columns(["bias_jump"])
        self.keep["bias_jump"] = self.observable_columns("bias_jump")

    def test(self, name: str, small: Fit, big: Fit, kind: str = "search") -> tuple[float, float]:
        """The nested test of adding ``name`` (``big`` = ``small`` + name; :data:`TESTS`, the search's own
        :func:`nested_test` by default), its p-value multiplied by the number of values its nonlinear
        parameter was searched over (the jump time: Bonferroni)."""
        if big.dof <= 0:  # the bigger model is saturated: nothing left to test it against (never named)
            return 0.0, 1.0
        f, p = TESTS[kind](small, big)
        return f, min(1.0, p * self.multiplicity.get(name, 1))

    def build_columns(self, names) -> None:
        x = self.inputs()
        for n in names:
            c = LIBRARY[n].columns_g(x)  # (K, 3, P)
            self.labels[n] = LIBRARY[n].param_labels(x)
            cols = np.transpose(c, (1, 0, 2)).reshape(3 * self.k, -1) * self.lsb
            self.cols[n] = np.concatenate([cols, self.nuisance_columns(n)], axis=1)
            self._white.pop(n, None)

    def nuisance_columns(self, name: str) -> np.ndarray:
        """(3K, Q) columns that come with effect ``name`` but are not its parameters (see NUISANCE)."""
        if NUISANCE.get(name) != "initial_leg" or self.ctx.heating is None or not np.any(self.ctx.heating == 0):
            return np.zeros((3 * self.k, 0))
        unknown = (np.asarray(self.ctx.heating) == 0).astype(float)
        out = np.zeros((3 * self.k, 3))
        for j in range(3):
            out[j * self.k:(j + 1) * self.k, j] = unknown
        return out

    def design(self, effects, extra=None) -> tuple[np.ndarray, list]:
        mats, names = [self.base], [("base", n) for n in self.base_names]
        for e in effects:
            keep = self.keep[e]
            mats.append(self.cols[e][:, keep])
            names += [(e, int(i)) for i in np.flatnonzero(keep)]
        if extra is not None:
            mats.append(extra[0])
            names += [("nuisance", n) for n in extra[1]]
        return np.concatenate(mats, axis=1), names

    def fit(self, effects, extra=None) -> Fit:
        """GLS fit of the baseline plus ``effects`` (plus ``extra`` = (columns, names) of nuisance factors);
        columns the others already span are dropped (the dof counts only what is determined)."""
        g, names = self.design(effects, extra)
        if "base" not in self._white:
            self._white["base"] = self.whiten(self.rows(self.base))
            self._white["y"] = self.whiten(self.rows(self.y))
        parts = [self._white["base"]] + [self.white_cols(e)[:, self.keep[e]] for e in effects]
        if extra is not None:
            parts.append(self.whiten(self.rows(extra[0])))
        gw, yw = np.concatenate(parts, axis=1), self._white["y"]
        keep = determined(gw)
        gw, g, names = gw[:, keep], g[:, keep], [n for n, kk in zip(names, keep) if kk]
        q, r = np.linalg.qr(gw)
        theta = np.linalg.solve(r, q.T @ yw)
        rinv = np.linalg.inv(r)
        white = yw - gw @ theta
        resid = self.spread(self.rows(self.y) - self.rows(g) @ theta)
        return Fit(theta, rinv @ rinv.T, float(white @ white), len(yw) - g.shape[1], resid, names, white)

    def observable_columns(self, name: str) -> np.ndarray:
        """Mask of the effect's columns the design determines beyond the baseline."""
        if "base_q" not in self._white:
            self._white["base_q"] = np.linalg.qr(self.whiten(self.rows(self.base)))[0]
        return independent(self._white["base_q"], self.white_cols(name))

    @property
    def baseline_name(self) -> str:
        return "pose_groups" if self.pose_free else "seed"

    def normalised(self, fit: Fit) -> np.ndarray:
        """(K, 3) whitened residuals (innovations), each ~N(0, 1) when the model holds."""
        return fit.white.reshape(3, self.k).T

    def marginal(self, fit: Fit) -> np.ndarray:
        """(K, 3) residuals in their own marginal standard deviations, ``r / sqrt(sem^2 + lsb^2 W_ii)``:
        for saying where a residual sits (a jump stays a step in time); not independent between steps."""
        var = self.sem.reshape(3, self.k) ** 2 + np.diag(self.wander_g2)[None, :] * self.lsb ** 2
        if self.rig_cov is not None:
            var = var + np.diag(self.rig_cov).reshape(3, self.k)
        return (fit.resid.reshape(3, self.k) / np.sqrt(var)).T

    def rms_g(self, fit: Fit) -> float:
        """RMS residual of a fit, g."""
        return float(np.sqrt(np.mean(fit.resid ** 2)) / self.lsb)

    def axis_chi2(self, fit: Fit) -> np.ndarray:
        """(3,) generalised chi-square of each output axis."""
        return np.sum(self.normalised(fit) ** 2, axis=0)


def _inverse_cholesky(v: np.ndarray) -> np.ndarray:
    """L^-1 for V = L L^T (lower triangular)."""
    chol = np.linalg.cholesky(v)
    return linalg.solve_triangular(chol, np.eye(len(v)), lower=True)


def determined(gw: np.ndarray) -> np.ndarray:
    """Mask of the whitened design's columns not spanned by the columns before them."""
    keep = np.ones(gw.shape[1], bool)
    if gw.shape[1] > gw.shape[0]:
        return independent(np.zeros((gw.shape[0], 0)), gw)
    _, r = np.linalg.qr(gw)
    norms = np.linalg.norm(gw, axis=0)
    d = np.abs(np.diag(r))
    bad = (d <= COLUMN_TOL * np.where(norms > 0, norms, 1.0)) | (norms == 0)
    if not bad.any():
        return keep
    return independent(np.zeros((gw.shape[0], 0)), gw)


def independent(basis: np.ndarray, cw: np.ndarray) -> np.ndarray:
    """Mask of the (whitened) columns ``cw`` that add a direction to the orthonormal ``basis`` (and to
    the columns kept before them)."""
    keep = np.zeros(cw.shape[1], bool)
    for i in range(cw.shape[1]):
        c = cw[:, i]
        norm = np.linalg.norm(c)
        if norm == 0:
            continue
        r = c - basis @ (basis.T @ c)
        if np.linalg.norm(r) > COLUMN_TOL * norm:
            keep[i] = True
            basis = np.concatenate([basis, (r / np.linalg.norm(r))[:, None]], axis=1)
    return keep


class RadialProblem(Problem):
    """Sessions with unknown poses that never repeat (an imu_tk-style hand-held recording): the
    magnitude model ``|M^-1 (a - b)| = 1 g`` as the baseline.

    The fit is linearised at the magnitude solution: each step's direction ``f_i`` is estimated from
    it, and only the component of each step's residual along ``u_i = unit(U^T f_i)`` (``U = M^-1``) is
    used, the one a change of the unknown direction cannot absorb (to first order). One row per step;
    its covariance is ``diag(sd_i^2) + (u_i . u_k) lsb^2 W_ik`` (sd_i: the step's standard error along
    u_i; W: the wander, independent per axis). Residuals are reported per axis as ``u_i r_i`` so the
    localisation and the verdict read them like any other session's. Only bias-type effects are
    candidates (poses unknown).
    """

    def __init__(self, steps: StepMeans, ctx, t0_c: float, t_ref_s: float) -> None:
        a = np.asarray(steps.mean_counts, float)
        sem = np.asarray(steps.sem_counts, float)
        mfit = fit_magnitude(a, sem, radius=1.0)
        u = np.linalg.inv(mfit.matrix)
        f = (a - mfit.bias) @ u.T
        f /= np.linalg.norm(f, axis=1)[:, None]
        self.u = None
        super().__init__(replace(steps, f_nominal_g=f), ctx, t0_c, t_ref_s)
        proj = f @ u
        self.u = proj / np.linalg.norm(proj, axis=1)[:, None]
        self.sd = np.sqrt(np.sum((self.u * sem) ** 2, axis=1))
        self._factors = self._cholesky()
        self._white = {}
        self.pose_free = True  # directions estimated, not known: no calibration, no force effects

    def _cholesky(self) -> list:
        if self.u is None:
            return []
        v = np.diag(self.sd ** 2) + (self.u @ self.u.T) * self.wander_g2 * self.lsb ** 2
        return [_inverse_cholesky(v)]

    @property
    def baseline_name(self) -> str:
        return "magnitude"

    def whiten(self, m: np.ndarray) -> np.ndarray:
        return self._factors[0] @ m

    def rows(self, m: np.ndarray) -> np.ndarray:
        """(3K, ...) axis-major rows -> (K, ...) components along each step's ``u_i``."""
        k = self.k
        return sum(self.u[:, j].reshape((k,) + (1,) * (m.ndim - 1)) * m[j * k:(j + 1) * k] for j in range(3))

    def spread(self, rows: np.ndarray) -> np.ndarray:
        return (self.u * rows[:, None]).T.ravel()

    def normalised(self, fit: Fit) -> np.ndarray:
        """Each step's radial innovation spread over the axes as ``sqrt(3) u_i z_i``: a step's mean square
        over the axes is ``z_i^2`` (~1 when the model holds), as for other sessions."""
        return np.sqrt(3.0) * self.u * fit.white[:, None]

    def marginal(self, fit: Fit) -> np.ndarray:
        """Each step's radial residual in its marginal standard deviation, spread as in :meth:`normalised`."""
        rows = self.rows(fit.resid)
        sd = np.sqrt(self.sd ** 2 + np.diag(self.wander_g2) * self.lsb ** 2)
        return np.sqrt(3.0) * self.u * (rows / sd)[:, None]

    def rms_g(self, fit: Fit) -> float:
        """RMS over the steps of the radial residual, g."""
        return float(np.sqrt(np.mean(np.sum(fit.resid.reshape(3, self.k) ** 2, axis=0))) / self.lsb)


def f_test(small: Fit, big: Fit) -> tuple[float, float]:
    """Nested-model F statistic and p-value (``big`` adds columns to ``small``): the chi-square drop
    per added column against the residual mean square of ``big`` (V known up to a common factor)."""
    added = _drop(small, big)
    if added is None or big.dof == 0:
        return 0.0, 1.0
    q, per_column = added
    f = per_column / (big.rss / big.dof)
    return float(f), float(stats.f.sf(f, q, big.dof))


def _drop(small: Fit, big: Fit) -> tuple[int, float] | None:
    """The number ``q`` of columns ``big`` adds to ``small`` and the chi-square drop per added column
    (negative drops, from rounding, count as 0); None when ``big`` adds none."""
    q = small.dof - big.dof
    if q <= 0 or big.dof < 0:
        return None
    return q, max(small.rss - big.rss, 0.0) / q


def known_noise_test(small: Fit, big: Fit) -> tuple[float, float]:
    """The chi-square drop per added column and its p-value with V known: the drop is chi-square on
    the ``q`` added columns under the null (the whitened residual is N(0, I))."""
    added = _drop(small, big)
    if added is None:
        return 0.0, 1.0
    q, per_column = added
    return float(per_column), float(stats.chi2.sf(per_column * q, q))


def nested_test(small: Fit, big: Fit) -> tuple[float, float]:
    """The search's test of ``big`` against ``small``.

    The statistic is ``t = (drop / q) / max(1, s^2)``: the chi-square drop over the ``q`` added
    columns per column, against the larger of the stated noise (1) and the mean square ``s^2 =
    rss / dof`` that ``big`` leaves. While ``big`` fits (its chi-square within its upper
    ``SCATTER_LEVEL`` quantile) the p-value is the statistic's exact tail with V right
    (:func:`floored_sf`); once it does not, V is not to be trusted as the scale and ``t`` (then the F
    statistic) is referred to the F distribution, whose tail is the larger for every ``t`` (the F
    test is this statistic's tail when V is understated by any factor). Returns (t, p).
    """
    added = _drop(small, big)
    if added is None:
        return 0.0, 1.0
    q, per_column = added
    t = per_column / max(1.0, big.rss / big.dof if big.dof else 1.0)
    if misfit(big.rss, big.dof, SCATTER_LEVEL)[0]:
        return float(t), float(stats.f.sf(t, q, big.dof))
    return float(t), floored_sf(t, q, big.dof)


def floored_sf(t: float, q: int, dof: int, lam: float = 0.0) -> float:
    """P(T > t) for ``T = (D / q) / max(1, R / dof)``, ``D ~ chi2_q(lam)`` and ``R ~ chi2_dof``
    independent (the drop and the residual of nested GLS fits): ``P(R <= dof) P(D > q t)`` plus the
    mean of ``P(D > q t R / dof)`` over ``R > dof`` (``FLOOR_GRID`` of its conditional quantiles),
    summed in logarithms (a strong effect's p-value stays a number, not 0). ``lam`` > 0 gives the
    power at that non-centrality."""
    def logsf(x):
        return stats.chi2.logsf(x, q) if lam == 0 else np.log(np.maximum(stats.ncx2.sf(x, q, lam), 1e-300))
    if dof <= 0:
        return float(np.exp(logsf(q * t)))
    below = stats.chi2.cdf(dof, dof)
    u = below + (1.0 - below) * (np.arange(FLOOR_GRID) + 0.5) / FLOOR_GRID
    r = stats.chi2.ppf(u, dof)
    above = special.logsumexp(logsf(q * t * r / dof)) - np.log(FLOOR_GRID)
    return float(np.exp(np.logaddexp(np.log(below) + logsf(q * t), np.log1p(-below) + above)))


#: the tests :func:`calib.discovery.search.candidate_pvalues` can report (the search uses ``search``)
TESTS = {"search": nested_test, "known_noise": known_noise_test, "scatter": f_test}


def pose_blocks(f: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """(K,) placement label of each step: runs of consecutive steps (in time) at one nominal pose share one
    (a pose visited again later is a new placement)."""
    order = np.argsort(t_s, kind="stable")
    poses = np.round(np.asarray(f, float)[order], 6)
    new = np.concatenate([[True], np.any(poses[1:] != poses[:-1], axis=1)])
    out = np.empty(len(order), int)
    out[order] = np.cumsum(new) - 1
    return out


def jump_times(t_s: np.ndarray) -> np.ndarray:
    """Candidate bias-jump times: midpoints between consecutive distinct step times that leave at least
    ``MIN_JUMP_SIDE`` steps on each side."""
    t = np.unique(np.asarray(t_s, float))
    mids = 0.5 * (t[:-1] + t[1:])
    return mids[MIN_JUMP_SIDE - 1:len(mids) - MIN_JUMP_SIDE + 1]


def scan_jump(prob: Problem, others: list, extra=None) -> float:
    """Put ``bias_jump`` at the step boundary that lowers chi2 most with ``others`` in the model."""
    best = (np.inf, prob.t_jump)
    for tj in prob.jump_grid:
        prob.set_jump(tj)
        rss = prob.fit(list(others) + ["bias_jump"], extra).rss
        if rss < best[0]:
            best = (rss, tj)
    prob.set_jump(best[1])
    return best[1]
