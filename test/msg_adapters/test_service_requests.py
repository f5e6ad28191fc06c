"""The dynamics services' requests read by joint name and refused naming the field, without ROS
(issue 21): plain objects with the requests' fields stand in for the generated types, so these
run where baxter_dynamics_interfaces is not built."""

from __future__ import annotations

import array
from types import SimpleNamespace

import numpy as np
import pytest

from baxter_dynamics_ros.errors import QueryError
from msg_adapters.dynamics_services import MAX_STATES, SERVICES, RequestReader, write_response

ARM = ("right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2")
WIDE = sorted(ARM + ("head_pan", "left_s0", "torso_t0"))


def request(names, compensate=False, **fields):
    return SimpleNamespace(name=list(names), compensate_effects=compensate, **{k: array.array("d", v) for k, v in fields.items()})


def test_a_superset_in_any_order_is_read_in_the_arms_order() -> None:
    q = np.arange(2 * len(WIDE), dtype=float).reshape(2, len(WIDE))
    out = RequestReader(ARM).read(request(WIDE, position=q.ravel()), SERVICES["gravity"], can_compensate=False)
    np.testing.assert_array_equal(out["q"], q[:, [WIDE.index(j) for j in ARM]])
    assert out["compensate"] is False


def test_every_input_of_a_service_is_read() -> None:
    x = np.random.default_rng(0).normal(size=(3, 7))
    out = RequestReader(ARM).read(request(ARM, True, position=x.ravel(), velocity=2 * x.ravel(), effort=3 * x.ravel()), SERVICES["forward_dynamics"], True)
    np.testing.assert_array_equal(out["qd"], 2 * x)
    np.testing.assert_array_equal(out["tau"], 3 * x)
    assert out["compensate"] is True


@pytest.mark.parametrize(
    ("names", "fields", "message"),
    [
        ((), {"position": []}, "name: empty"),
        (ARM[1:], {"position": [0.0] * 6}, "name: missing right_s0"),
        (("right_s9",) + ARM[1:], {"position": [0.0] * 7}, "name: missing right_s0 (unknown to this arm: 'right_s9')"),
        (ARM + ("right_w2",), {"position": [0.0] * 8}, "name: 'right_w2' appears more than once"),
        (ARM, {"position": [0.0] * 13}, "position: 13 values for 7 names"),
        (ARM, {"position": [0.0] * 7 * (MAX_STATES + 1)}, f"position: {MAX_STATES + 1} states, more than the limit"),
        (ARM, {"position": [0.0] * 6 + [float("nan")]}, "position: nan at state 0, joint right_w2"),
    ],
)
def test_bad_requests_name_the_field(names, fields, message: str) -> None:
    with pytest.raises(QueryError, match="^" + message.replace("(", r"\(").replace(")", r"\)")):
        RequestReader(ARM).read(request(names, **fields), SERVICES["mass_matrix"], can_compensate=True)


def test_a_non_finite_value_beside_the_arm_is_not_read() -> None:
    position = np.zeros(len(WIDE))
    position[WIDE.index("head_pan")] = np.inf
    RequestReader(ARM).read(request(WIDE, position=position), SERVICES["gravity"], can_compensate=False)


def test_compensation_needs_effects_and_arrays_need_positions_length() -> None:
    reader = RequestReader(ARM)
    with pytest.raises(QueryError, match="^compensate_effects: this node has no effects"):
        reader.read(request(ARM, True, position=[0.0] * 7), SERVICES["gravity"], can_compensate=False)
    with pytest.raises(QueryError, match="^acceleration: 6 values, expected 7"):
        reader.read(request(ARM, position=[0.0] * 7, velocity=[0.0] * 7, acceleration=[0.0] * 6), SERVICES["inverse_dynamics"], True)


def test_responses_carry_names_rows_and_refuse_non_finite_results() -> None:
    response = write_response(SimpleNamespace(), SERVICES["flange_kinematics"], ARM, (np.zeros((2, 4, 4)), np.ones((2, 6, 7))))
    assert response.success and response.message == "2 states" and response.name == list(ARM)
    assert len(response.pose) == 32 and list(response.jacobian) == [1.0] * 84
    response = write_response(SimpleNamespace(), SERVICES["gravity"], ARM, (np.full((1, 7), np.inf),))
    assert not response.success and response.message.startswith("effort: the model gives a non-finite value")
