"""``get_params`` of the learned reconstructors, read from ``__init__`` (scikit-learn's way).

The estimator contract (house style 10) keeps hyperparameters only in ``__init__``, each stored
under its own name; so the constructor's signature lists them, and one implementation serves
every estimator instead of a hand-written dict per class that can drift from the signature.
"""

from __future__ import annotations

import inspect
from typing import Any


class ParamsMixin:
    """Adds ``get_params``: every ``__init__`` argument's current value, JSON-able."""

    @classmethod
    def param_names(cls) -> list[str]:
        """Names of the hyperparameters, in the order of the constructor's signature."""
        sig = inspect.signature(cls.__init__)
        return [n for n, p in sig.parameters.items()
                if n != 'self' and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]

    def get_params(self) -> dict[str, Any]:
        """Hyperparameters as a JSON-able dict (tuples as lists): the config in model files."""
        params = {name: getattr(self, name) for name in self.param_names()}
        return {k: list(v) if isinstance(v, tuple) else v for k, v in params.items()}
