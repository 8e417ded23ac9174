"""Wrappers of the loop in DESIGN.md: parameter refresh and domain randomisation.

:class:`ParameterRefresh` closes the loop "identification → FitResult → env":
it re-reads a FitResult (a JSON file a running identification rewrites, a
callable, or a fixed FitResult) between episodes or at a given step of each
episode, applies it when it changed and logs what changed.

:class:`DomainRandomization` draws the plant parameters of every episode from
the FitResult's covariance (or within bounds), seeded by the environment's
``np_random``, so that a controller is trained on the uncertainty of the
identification.

Both act on the environment's parameter interface
(``env.unwrapped.set_parameters`` / ``set_randomization``), which the native
vector environments offer too.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from thermogym.errors import ConfigError
from thermogym.fitresult import FitResult, load_fit

__all__ = ["DomainRandomization", "ParameterRefresh"]

log = logging.getLogger("thermogym.envs")

Source = FitResult | str | os.PathLike[str] | Mapping[str, Any] | Callable[[], Any]


class ParameterRefresh(gym.Wrapper):
    """Re-read a FitResult between episodes or at a step, apply it when it changed.

    Parameters
    ----------
    env : gymnasium.Env
        A thermogym environment.
    source : FitResult, path, dict or callable
        A path is re-read at every check and applied when its content
        changed; a callable is called at every check and may return ``None``
        (no new result) or a FitResult-like; a FitResult or dict is applied
        once.
    at_reset : bool
        Check at every reset (between episodes).
    at_step : int, optional
        Also check before step ``at_step`` of every episode (0-based): the
        dynamics change from that step on, the state is kept.

    Attributes
    ----------
    log : list of dict
        One entry per applied change: ``episode``, ``step``,
        ``old_fingerprint``, ``new_fingerprint``, ``changed``
        (``{name: (old, new)}``) and ``source``.

    Notes
    -----
    Each applied change is also logged on the ``thermogym.envs`` logger (INFO)
    and returned in the ``info`` of that reset or step under
    ``"parameter_refresh"``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> from thermogym.fitresult import FitResult
    >>> from thermogym.models import AXT211
    >>> new = FitResult.from_model(AXT211(), {"C_P": 25.0}, method="example")
    >>> env = ParameterRefresh(gym.make("thermogym/AXT211Valve-v0"), new)
    >>> obs, info = env.reset(seed=0)
    >>> info["parameter_refresh"]["changed"]["C_P"]
    (18.0, 25.0)
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        source: Source,
        *,
        at_reset: bool = True,
        at_step: int | None = None,
    ) -> None:
        super().__init__(env)
        if not hasattr(env.unwrapped, "set_parameters"):
            raise ConfigError(
                f"ParameterRefresh needs a thermogym environment; got {type(env.unwrapped)}"
            )
        if at_step is not None and (not isinstance(at_step, int) or at_step < 0):
            raise ConfigError(f"at_step is {at_step!r}; expected None or an integer >= 0")
        self.source = source
        self.at_reset = bool(at_reset)
        self.at_step = at_step
        self.log: list[dict[str, Any]] = []
        self._stamp: Any = None
        self._used_once = False
        self._episode = -1
        self._step = 0

    def _poll(self) -> FitResult | None:
        src = self.source
        if isinstance(src, str | os.PathLike):
            p = Path(src)
            if not p.exists():
                log.warning("ParameterRefresh: %s does not exist (yet); parameters kept", p)
                return None
            st = p.stat()
            stamp = (st.st_mtime_ns, st.st_size)
            if stamp == self._stamp:
                return None
            self._stamp = stamp
            return load_fit(p)
        if callable(src):
            got = src()
            return None if got is None else load_fit(got)
        if self._used_once:
            return None
        self._used_once = True
        return load_fit(src)

    def _check(self) -> dict[str, Any] | None:
        fit = self._poll()
        if fit is None:
            return None
        unwrapped: Any = self.env.unwrapped  # a thermogym environment (checked in __init__)
        if fit.fingerprint() == unwrapped.fit.fingerprint():
            return None
        rec = unwrapped.set_parameters(fit)
        rec.update(
            episode=self._episode,
            step=self._step,
            source=str(self.source) if not callable(self.source) else repr(self.source),
        )
        self.log.append(rec)
        log.info(
            "parameters refreshed at episode %d step %d: %s",
            self._episode,
            self._step,
            {k: v for k, v in rec["changed"].items()},
        )
        return rec

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Check for a new FitResult, then reset."""
        self._episode += 1
        self._step = 0
        rec = self._check() if self.at_reset else None
        obs, info = self.env.reset(seed=seed, options=options)
        if rec is not None:
            info["parameter_refresh"] = rec
        return obs, info

    def step(self, action: Any):
        """Check for a new FitResult at ``at_step``, then step."""
        rec = self._check() if self.at_step is not None and self._step == self.at_step else None
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._step += 1
        if rec is not None:
            info["parameter_refresh"] = rec
        return obs, reward, terminated, truncated, info


class DomainRandomization(gym.Wrapper):
    """Draw the plant parameters of every episode, seeded by the environment's ``np_random``.

    Parameters
    ----------
    env : gymnasium.Env
        A thermogym environment.
    method : {"covariance", "bounds", "relative"}
        ``"covariance"``: multivariate normal with the FitResult's covariance
        (or standard errors), :meth:`FitResult.sample`; ``"bounds"``: uniform
        within the FitResult's bounds (or ``bounds``); ``"relative"``:
        uniform within ``value (1 ± scale)``.
    fit : FitResult, path or dict, optional
        Centre of the distribution (default: the environment's FitResult).
    scale : float
        Standard-deviation multiplier (``"covariance"``) or relative half
        width (``"relative"``).
    names : sequence of str, optional
        Parameters to randomise (``"bounds"``, ``"relative"``; default: all
        not fixed in the FitResult).
    bounds : mapping, optional
        ``{name: (low, high)}`` for ``"bounds"``.

    Notes
    -----
    The drawn parameter set is returned in the reset ``info["parameters"]``.
    Draws failing the model's validity checks are drawn again.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> env = DomainRandomization(gym.make("thermogym/TCLab-v0"), "covariance", scale=3.0)
    >>> a = env.reset(seed=1)[1]["parameters"]["C_H"]
    >>> b = env.reset(seed=1)[1]["parameters"]["C_H"]
    >>> c = env.reset(seed=2)[1]["parameters"]["C_H"]
    >>> a == b, a == c
    (True, False)
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        method: str = "covariance",
        *,
        fit: FitResult | str | os.PathLike[str] | Mapping[str, Any] | None = None,
        scale: float = 1.0,
        names: Sequence[str] | None = None,
        bounds: Mapping[str, tuple[float, float]] | None = None,
    ) -> None:
        super().__init__(env)
        u: Any = env.unwrapped  # a thermogym environment (duck-typed: checked here)
        if not hasattr(u, "set_randomization"):
            raise ConfigError(f"DomainRandomization needs a thermogym environment; got {type(u)}")
        if fit is not None:
            u.set_parameters(fit)
        kw: dict[str, Any] = {"scale": scale}
        if names is not None:
            kw["names"] = list(names)
        if bounds is not None:
            kw["bounds"] = dict(bounds)
        u.set_randomization(method, **kw)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Reset with a freshly drawn parameter set (reported in ``info["parameters"]``)."""
        obs, info = self.env.reset(seed=seed, options=options)
        u: Any = self.env.unwrapped
        info["parameters"] = dict(
            zip(u.model.param_names, np.asarray(u.theta)[0].tolist(), strict=True)
        )
        return obs, info
