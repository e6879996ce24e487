"""filterpy's unscented Kalman filter with a process model over all sigma points at once.

filterpy's ``UnscentedKalmanFilter`` calls ``fx`` and ``hx`` once per sigma point from Python loops
and forms the cross covariance with another loop. :class:`BatchUnscentedKalmanFilter` keeps
filterpy's algorithm (its sigma points, weights, unscented transform, gain and covariance update)
and replaces those loops: ``fx_batch`` maps the whole (2n+1, n) sigma array in one compiled call,
``hx_batch`` does the same for the measurement, the cross covariance is one matrix product, and the
sigma points are formed with array operations. It also keeps the covariance symmetric after every
step, and its sigma-point square root repairs a covariance that rounding has pushed off positive
definiteness (counted in ``repairs``), so hours of filtering never stop on a failed Cholesky
factorisation.
"""

from __future__ import annotations

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter, unscented_transform


class RobustSquareRoot:
    """Matrix square root for the sigma points: Cholesky, or an eigenvalue-clipped root if it fails.

    Returns ``U`` with ``U.T @ U == A`` (filterpy uses the rows of ``U``); ``repairs`` counts the
    matrices that were not numerically positive definite.
    """

    def __init__(self, relative_floor: float = 1e-12):
        self.relative_floor = float(relative_floor)
        self.repairs = 0

    def __call__(self, matrix: np.ndarray) -> np.ndarray:
        try:
            return np.linalg.cholesky(matrix).T
        except np.linalg.LinAlgError:
            self.repairs += 1
            values, vectors = np.linalg.eigh(0.5 * (matrix + matrix.T))
            floor = self.relative_floor * max(float(np.max(np.abs(values))), 1e-300)
            return (vectors * np.sqrt(np.maximum(values, floor))).T


class VectorizedSigmaPoints(MerweScaledSigmaPoints):
    """Van der Merwe's scaled sigma points, formed with array operations instead of a loop.

    Same points, order and weights as filterpy's ``MerweScaledSigmaPoints``: ``x``, then ``x + U[k]``,
    then ``x - U[k]`` for the rows ``U[k]`` of the square root of ``(n + lambda) P``.
    """

    def sigma_points(self, x, P):
        x = np.asarray(x, dtype=float)
        lambda_ = self.alpha ** 2 * (self.n + self.kappa) - self.n
        root = self.sqrt((lambda_ + self.n) * P)
        return np.vstack([x, x + root, x - root])


def sigma_points(dim_x: int, alpha: float, beta: float, kappa: float) -> VectorizedSigmaPoints:
    """Van der Merwe's scaled sigma points with a :class:`RobustSquareRoot`."""
    return VectorizedSigmaPoints(dim_x, alpha=alpha, beta=beta, kappa=kappa, sqrt_method=RobustSquareRoot())


class BatchUnscentedKalmanFilter(UnscentedKalmanFilter):
    """filterpy UKF whose process and measurement models take every sigma point in one call.

    Parameters
    ----------
    dim_x, dim_z : state and measurement sizes.
    points : filterpy sigma-point object (e.g. :func:`sigma_points`).
    fx_batch : ``fx_batch(sigmas (2n+1, n), dt, **fx_args) -> (2n+1, n)``.
    hx_batch : ``hx_batch(sigmas (2n+1, n)) -> (2n+1, dim_z)``.
    """

    def __init__(self, dim_x: int, dim_z: int, points, fx_batch, hx_batch, dt: float = 1.0):
        super().__init__(dim_x=dim_x, dim_z=dim_z, dt=dt, hx=lambda x: hx_batch(x[None, :])[0], fx=None,
                         points=points)
        self.fx_batch = fx_batch
        self.hx_batch = hx_batch

    @property
    def repairs(self) -> int:
        """Covariances whose square root needed an eigenvalue repair."""
        return getattr(self.points_fn.sqrt, "repairs", 0)

    def compute_process_sigmas(self, dt, fx=None, **fx_args):
        sigmas = self.points_fn.sigma_points(self.x, self.P)
        self.sigmas_f = self.fx_batch(sigmas, dt, **fx_args)

    def cross_variance(self, x, z, sigmas_f, sigmas_h):
        return ((sigmas_f - x) * self.Wc[:, None]).T @ (sigmas_h - z)

    def predict(self, dt=None, UT=None, fx=None, **fx_args):
        super().predict(dt=dt, UT=UT, fx=fx, **fx_args)
        self.P = 0.5 * (self.P + self.P.T)

    def update(self, z, R=None, UT=None, hx=None, **hx_args):
        """filterpy's update with the measurement model applied to all sigma points at once."""
        if z is None or UT is not None or hx is not None or hx_args:
            super().update(z, R=R, UT=UT, hx=hx, **hx_args)
            self.P = 0.5 * (self.P + self.P.T)
            return
        R = self.R if R is None else R
        self.sigmas_h = self.hx_batch(self.sigmas_f)
        zp, self.S = unscented_transform(self.sigmas_h, self.Wm, self.Wc, R, self.z_mean, self.residual_z)
        self.SI = self.inv(self.S)
        Pxz = self.cross_variance(self.x, zp, self.sigmas_f, self.sigmas_h)
        self.K = Pxz @ self.SI
        self.y = self.residual_z(z, zp)
        self.x = self.state_add(self.x, self.K @ self.y)
        self.P = self.P - self.K @ self.S @ self.K.T
        self.P = 0.5 * (self.P + self.P.T)
        self.z = np.array(z, dtype=float)
        self.x_post = self.x.copy()
        self.P_post = self.P.copy()
        self._log_likelihood = None
        self._likelihood = None
        self._mahalanobis = None

    def gated_update(self, z, threshold: float, max_inflation: float = 1.0) -> tuple[bool, float, float]:
        """Update with ``z`` unless its innovation fails the chi-square gate; after :meth:`predict`.

        The squared Mahalanobis distance ``d2 = y^T S^-1 y`` of the innovation ``y`` (``S = Pzz + R``
        from the unscented transform) is compared with ``threshold``. Beyond it, the predicted
        covariance is scaled by the smallest factor ``lambda`` (at most ``max_inflation``) that
        brings ``y^T (lambda Pzz + R)^-1 y`` to the threshold: a reading a modestly overconfident
        prediction cannot explain widens the prediction instead of being thrown away (the
        measurement model is linear, so scaling the sigma spread scales ``Pzz`` and ``Pxz``
        exactly). A reading that needs more is rejected and leaves the prediction untouched.

        Returns
        -------
        (accepted, d2, lambda) with ``d2`` the distance before any scaling.
        """
        self.sigmas_h = self.hx_batch(self.sigmas_f)
        zp, Pzz = unscented_transform(self.sigmas_h, self.Wm, self.Wc, None, self.z_mean, self.residual_z)
        y = self.residual_z(z, zp)
        Pxz = self.cross_variance(self.x, zp, self.sigmas_f, self.sigmas_h)
        R = self.R
        try:
            S = Pzz + R
            SI = self.inv(S)
            d2 = float(y @ SI @ y)
            scale, distance = 1.0, d2
            for _ in range(60):         # doubling, then bisection on the monotone distance(lambda)
                if not (np.isfinite(distance) and distance > threshold) or scale >= max_inflation:
                    break
                scale = min(2.0 * scale, max_inflation)
                distance = float(y @ np.linalg.solve(scale * Pzz + R, y))
            if scale > 1.0 and np.isfinite(distance) and distance <= threshold:
                low, high = scale / 2.0, scale
                for _ in range(20):
                    middle = 0.5 * (low + high)
                    if float(y @ np.linalg.solve(middle * Pzz + R, y)) > threshold:
                        low = middle
                    else:
                        high = middle
                scale = high
                S = scale * Pzz + R
                SI = self.inv(S)
                distance = float(y @ SI @ y)
        except np.linalg.LinAlgError:
            return False, np.inf, 1.0
        self.S, self.SI, self.y = S, SI, y
        if not (np.isfinite(distance) and distance <= threshold * (1.0 + 1e-9)):
            self.S, self.SI = Pzz + R, self.inv(Pzz + R)
            return False, d2, 1.0
        if scale > 1.0:
            self.P = scale * self.P
            Pxz = scale * Pxz
        self.K = Pxz @ SI
        self.x = self.state_add(self.x, self.K @ y)
        self.P = self.P - self.K @ S @ self.K.T
        self.P = 0.5 * (self.P + self.P.T)
        self.z = np.array(z, dtype=float)
        self.x_post = self.x.copy()
        self.P_post = self.P.copy()
        return True, d2, scale

    def innovation_log_likelihood(self, max_distance: float = np.inf) -> float:
        """Gaussian log-likelihood of the last innovation (faster than filterpy's scipy call).

        ``max_distance`` caps the squared Mahalanobis distance (a rejected reading counts as one
        at the gate, so that it neither rewards nor ruins a noise setting).
        """
        y = self.y
        logdet = np.log(np.linalg.det(self.S)) if y.size != 3 else np.log(_det3(self.S))
        return float(-0.5 * (min(float(y @ self.SI @ y), max_distance) + logdet + y.size * np.log(2.0 * np.pi)))


def _det3(a: np.ndarray) -> float:
    return float(a[0, 0] * (a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]) - a[0, 1] * (a[1, 0] * a[2, 2] - a[1, 2] * a[2, 0])
                 + a[0, 2] * (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]))
