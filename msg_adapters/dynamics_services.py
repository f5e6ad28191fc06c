"""The dynamics services' requests and responses (``baxter_dynamics_interfaces/srv``) ↔ one arm's arrays.

Every request carries ``name`` (any superset of the arm's 7 joints, any order, as the topic input)
and flat float64 arrays holding ``len(name)`` values per state, states one after another. A
request is read into (N, 7) arrays in the arm's joint order, or refused with a
:class:`~baxter_dynamics_ros.errors.QueryError` whose message names the field:

- ``name``: empty, a name twice, or one of the arm's joints missing (names that are not the arm's
  are listed as unknown in that message; beside all 7 they are ignored);
- ``position``: no state, not a whole number of states (len(position) % len(name) ≠ 0), or more than
  :data:`MAX_STATES` states;
- ``velocity``, ``acceleration``, ``effort``: not as long as ``position``;
- any of them: a non-finite value (NaN, ±inf) at one of the arm's joints (the others are not read);
- ``compensate_effects``: true on a node without effects.

Responses get the arm's 7 names, the values row-major (states × 7, × 4 × 4, × 6 × 7 or × 7 × 7),
``success`` and a one-line ``message``. :data:`SERVICES` says, per service, which request fields
feed which argument of :class:`~baxter_dynamics_ros.core.queries.DynamicsQueries` and which
response fields its results fill. The generated types are imported by :func:`service_types` only.
"""

from __future__ import annotations

import array
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from baxter_dynamics_ros.errors import QueryError

__all__ = ["MAX_STATES", "SERVICES", "RequestReader", "ServiceLayout", "refuse", "service_types", "write_response"]

#: The most states one request may carry (a 10,000-state mass-matrix answer is 3.9 MB).
MAX_STATES = 10_000


class ServiceLayout(NamedTuple):
    """One service: its type's name in baxter_dynamics_interfaces/srv, the request arrays with the
    query argument each feeds, the response arrays its results fill (in the query's result order),
    and whether the request has ``compensate_effects``."""

    srv_type: str
    inputs: tuple[tuple[str, str], ...]
    outputs: tuple[str, ...]
    compensates: bool = True


#: The node serves ``~/compute_<key>``, answered by ``DynamicsQueries.<key>``.
SERVICES = {
    "gravity": ServiceLayout("Gravity", (("position", "q"),), ("effort",)),
    "inverse_dynamics": ServiceLayout(
        "InverseDynamics", (("position", "q"), ("velocity", "qd"), ("acceleration", "qdd")), ("effort",)
    ),
    "mass_matrix": ServiceLayout("MassMatrix", (("position", "q"),), ("mass_matrix",)),
    "forward_dynamics": ServiceLayout(
        "ForwardDynamics", (("position", "q"), ("velocity", "qd"), ("effort", "tau")), ("acceleration",)
    ),
    "flange_kinematics": ServiceLayout("FlangeKinematics", (("position", "q"),), ("pose", "jacobian"), compensates=False),
}


def service_types() -> dict[str, type]:
    """The generated service types by :data:`SERVICES` key; raises ImportError when
    baxter_dynamics_interfaces is not built (``./dev`` builds it given cmake and a C++ compiler)."""
    from baxter_dynamics_interfaces import srv

    return {key: getattr(srv, layout.srv_type) for key, layout in SERVICES.items()}


class RequestReader:
    """Reads requests into the arrays of one arm, by joint name; the name → column map of the last
    ``name`` list is kept, since a client usually sends the same names every time."""

    def __init__(self, joint_names: Sequence[str], max_states: int = MAX_STATES) -> None:
        self.joint_names = tuple(joint_names)
        self.max_states = max_states
        self._names: tuple[str, ...] | None = None
        self._columns = np.zeros(0, dtype=np.intp)

    def columns(self, names: Sequence[str]) -> np.ndarray:
        """The index in ``names`` of each of the arm's joints (raises QueryError naming ``name``)."""
        names = tuple(names)
        if names == self._names:
            return self._columns
        if not names:
            raise QueryError(f"name: empty; give the arm's joints {', '.join(self.joint_names)} (any order, others allowed)")
        index: dict[str, int] = {}
        for k, n in enumerate(names):
            if n in index:
                raise QueryError(f"name: {n!r} appears more than once")
            index[n] = k
        missing = [j for j in self.joint_names if j not in index]
        if missing:
            unknown = [n for n in names if n not in self.joint_names]
            raise QueryError(
                f"name: missing {', '.join(missing)}"
                + (f" (unknown to this arm: {', '.join(map(repr, unknown))})" if unknown else "")
                + f"; the arm's joints are {', '.join(self.joint_names)}"
            )
        self._names, self._columns = names, np.array([index[j] for j in self.joint_names], dtype=np.intp)
        return self._columns

    def read(self, request: Any, layout: ServiceLayout, can_compensate: bool) -> dict[str, Any]:
        """The query's keyword arguments: (N, 7) float64 arrays by argument name and, if the
        service has it, ``compensate``. Raises QueryError naming the field."""
        columns = self.columns(request.name)
        width = len(request.name)
        n_values = len(request.position)
        if n_values == 0 or n_values % width:
            raise QueryError(
                f"position: {n_values} values for {width} names; expected len(name) values per state, at least one state"
            )
        states = n_values // width
        if states > self.max_states:
            raise QueryError(f"position: {states} states, more than the limit of {self.max_states} per request; split the request")
        out: dict[str, Any] = {}
        for field, argument in layout.inputs:
            values = getattr(request, field)
            if len(values) != n_values:
                raise QueryError(f"{field}: {len(values)} values, expected {n_values} (as position: {states} states × {width} names)")
            arm = np.frombuffer(values, dtype=np.float64).reshape(states, width)[:, columns]
            bad = ~np.isfinite(arm)
            if bad.any():
                s, j = np.argwhere(bad)[0]
                raise QueryError(f"{field}: {arm[s, j]} at state {s}, joint {self.joint_names[j]}; values must be finite")
            out[argument] = arm
        if layout.compensates:
            if request.compensate_effects and not can_compensate:
                raise QueryError("compensate_effects: this node has no effects loaded (start it with effects_file:=<effects.yaml>)")
            out["compensate"] = bool(request.compensate_effects)
        return out


def _doubles(values: np.ndarray) -> array.array:
    """A float64 array as the array.array a message's float64[] field takes without a copy per element."""
    return array.array("d", np.ascontiguousarray(values, dtype=np.float64).tobytes())


def write_response(response: Any, layout: ServiceLayout, joint_names: Sequence[str], results: Sequence[np.ndarray]) -> Any:
    """Fill ``response`` with the arm's names and ``results`` (one array per output field, first axis
    the states); refused instead if a result is not finite."""
    for field, values in zip(layout.outputs, results):
        if not np.isfinite(values).all():
            return refuse(response, f"{field}: the model gives a non-finite value for these states")
    response.name = list(joint_names)
    for field, values in zip(layout.outputs, results):
        setattr(response, field, _doubles(values))
    states = len(results[0])
    response.success = True
    response.message = f"{states} state{'s' if states != 1 else ''}"
    return response


def refuse(response: Any, message: str) -> Any:
    """``response`` as a refusal: success false, the one-line reason, no values."""
    response.success = False
    response.message = message
    return response
