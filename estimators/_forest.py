"""Regression forests as flat numpy node arrays, independent of scikit-learn's tree objects.

A fitted `RandomForestRegressor` is converted once into five arrays over all nodes of all trees
(global node ids), so the forest can be predicted, saved without pickle and exported to the
real-time form with numpy alone. Leaves point to themselves and compare against +inf, so a walk of
`depth` steps from the roots ends on every tree's leaf whatever the path length.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FlatForest:
    """Node arrays of a regression forest.

    Attributes
    ----------
    feature : ndarray of intp, shape (n_nodes,)
        Column of x tested at each node (0 at leaves).
    threshold : ndarray of float64, shape (n_nodes,)
        Split threshold: go left if ``float32(x[feature]) <= threshold`` (+inf at leaves).
    left, right : ndarray of intp, shape (n_nodes,)
        Global ids of the children (the node itself at leaves).
    value : ndarray of float64, shape (n_nodes, n_outputs)
        Mean training target of each node.
    roots : ndarray of intp, shape (n_trees,)
        Global id of each tree's root.
    depth : int
        Largest number of splits on any root-to-leaf path.
    """

    feature: np.ndarray
    threshold: np.ndarray
    left: np.ndarray
    right: np.ndarray
    value: np.ndarray
    roots: np.ndarray
    depth: int

    @classmethod
    def from_sklearn(cls, forest) -> "FlatForest":
        """Convert a fitted scikit-learn forest (or any object with `estimators_` of trees)."""
        features, thresholds, lefts, rights, values, roots = [], [], [], [], [], []
        offset, depth = 0, 0
        for tree in (estimator.tree_ for estimator in forest.estimators_):
            node_ids = np.arange(tree.node_count, dtype=np.intp)
            is_leaf = tree.children_left < 0
            features.append(np.where(is_leaf, 0, tree.feature).astype(np.intp))
            thresholds.append(np.where(is_leaf, np.inf, tree.threshold))
            lefts.append(np.where(is_leaf, node_ids, tree.children_left) + offset)
            rights.append(np.where(is_leaf, node_ids, tree.children_right) + offset)
            values.append(tree.value[:, :, 0])
            roots.append(offset)
            offset += tree.node_count
            depth = max(depth, tree.max_depth)
        return cls(
            feature=np.concatenate(features),
            threshold=np.concatenate(thresholds),
            left=np.concatenate(lefts),
            right=np.concatenate(rights),
            value=np.ascontiguousarray(np.concatenate(values), dtype=np.float64),
            roots=np.asarray(roots, dtype=np.intp),
            depth=int(depth),
        )

    def arrays(self) -> dict[str, np.ndarray]:
        """The forest as named arrays (for saving)."""
        return {"feature": self.feature, "threshold": self.threshold, "left": self.left,
                "right": self.right, "value": self.value, "roots": self.roots,
                "depth": np.asarray(self.depth)}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> "FlatForest":
        """Inverse of `arrays`, with consistency checks on the node ids."""
        forest = cls(
            feature=np.asarray(arrays["feature"], dtype=np.intp),
            threshold=np.asarray(arrays["threshold"], dtype=np.float64),
            left=np.asarray(arrays["left"], dtype=np.intp),
            right=np.asarray(arrays["right"], dtype=np.intp),
            value=np.asarray(arrays["value"], dtype=np.float64),
            roots=np.asarray(arrays["roots"], dtype=np.intp),
            depth=int(arrays["depth"]),
        )
        n_nodes = forest.threshold.shape[0]
        for name in ("feature", "left", "right"):
            if getattr(forest, name).shape != (n_nodes,):
                raise ValueError(f"forest array {name!r} does not match {n_nodes} nodes.")
        ids = np.concatenate([forest.left, forest.right, forest.roots])
        ids_inside = ids.min(initial=0) >= 0 and ids.max(initial=0) < n_nodes
        if forest.value.shape[0] != n_nodes or not ids_inside:
            raise ValueError("forest arrays are inconsistent: a node id points outside the forest.")
        return forest

    def predict(self, X: np.ndarray, chunk_size: int = 4096) -> np.ndarray:
        """Average tree prediction for each row of X, shape (n_samples, n_outputs).

        All trees are walked at once, `chunk_size` rows at a time to bound memory.
        """
        rounded = X.astype(np.float32)
        n_samples, n_trees = X.shape[0], self.roots.shape[0]
        prediction = np.empty((n_samples, self.value.shape[1]))
        for start in range(0, n_samples, chunk_size):
            block = rounded[start:start + chunk_size]
            rows = np.arange(block.shape[0])[:, None]
            nodes = np.broadcast_to(self.roots, (block.shape[0], n_trees))
            for _ in range(self.depth):
                goes_left = block[rows, self.feature[nodes]] <= self.threshold[nodes]
                advanced = np.where(goes_left, self.left[nodes], self.right[nodes])
                if np.array_equal(advanced, nodes):
                    break
                nodes = advanced
            prediction[start:start + chunk_size] = self.value[nodes].mean(axis=1)
        return prediction
