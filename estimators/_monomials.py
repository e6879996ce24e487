"""Monomials of a feature vector up to a degree, and their re-expansion under an affine map.

Monomials are ordered by degree, then lexicographically by their sorted factor indices (the
order of scikit-learn's `PolynomialFeatures` without the bias column). Each monomial of degree
k >= 2 is one monomial of degree k - 1 (its "parent") times one feature (its last "factor"), so
all of them are computed with one product per degree.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MonomialPlan:
    """Which products form the monomials of `n_features` variables up to `degree`.

    Attributes
    ----------
    n_features : int
    degree : int
    terms : tuple of tuple of int
        Sorted factor indices of every monomial, degree 1 first.
    parents, factors : tuple of ndarray of int
        For each degree k >= 2 (entry k - 2): index of each monomial's parent among the
        monomials of degree k - 1, and the index of its last factor in x.
    """

    n_features: int
    degree: int
    terms: tuple
    parents: tuple
    factors: tuple

    @classmethod
    def build(cls, n_features: int, degree: int) -> "MonomialPlan":
        """Plan the monomials of `n_features` variables of degree 1 to `degree`."""
        levels = [[(i,) for i in range(n_features)]]
        parents, factors = [], []
        for _ in range(2, degree + 1):
            previous = {term: index for index, term in enumerate(levels[-1])}
            level = list(itertools.combinations_with_replacement(range(n_features),
                                                                 len(levels) + 1))
            parents.append(np.array([previous[term[:-1]] for term in level], dtype=np.intp))
            factors.append(np.array([term[-1] for term in level], dtype=np.intp))
            levels.append(level)
        terms = tuple(term for level in levels for term in level)
        return cls(n_features, degree, terms, tuple(parents), tuple(factors))

    @property
    def n_terms(self) -> int:
        return len(self.terms)

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        """All monomials of the rows of X, shape (n_samples, n_terms)."""
        blocks = [X]
        for parent, factor in zip(self.parents, self.factors):
            blocks.append(blocks[-1][:, parent] * X[:, factor])
        return np.hstack(blocks)

    def reexpand(self, coef: np.ndarray, intercept: np.ndarray, slope: np.ndarray,
                 offset: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rewrite a polynomial in ``z = slope * x + offset`` as a polynomial in x.

        Each monomial of z is a product of factors ``slope_i x_i + offset_i``; expanding the
        product distributes its coefficient over the monomials of x formed by the kept factors.
        The result is exact up to rounding.

        Parameters
        ----------
        coef : ndarray, shape (n_terms, n_targets)
            Coefficients of the monomials of z.
        intercept : ndarray, shape (n_targets,)
        slope, offset : ndarray, shape (n_features,)

        Returns
        -------
        coef_x : ndarray, shape (n_terms, n_targets)
        intercept_x : ndarray, shape (n_targets,)
        """
        position = {term: index for index, term in enumerate(self.terms)}
        coef_x = np.zeros_like(coef)
        intercept_x = intercept.astype(np.float64).copy()
        for index, term in enumerate(self.terms):
            for keep in itertools.product((True, False), repeat=len(term)):
                kept = tuple(f for f, k in zip(term, keep) if k)
                factor = np.prod([slope[f] if k else offset[f] for f, k in zip(term, keep)])
                if kept:
                    coef_x[position[kept]] += factor * coef[index]
                else:
                    intercept_x += factor * coef[index]
        return coef_x, intercept_x
