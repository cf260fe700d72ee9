"""WHEEL (SPACAR type 12): exact kernels and slip kernels, invariance, rolling, deck errors,
and the clean refusal of every analysis until the solvers learn slips (rolling-contact spec
A1, A2, A4)."""
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import job_from_text
from spacarpy.elements.registry import KINDS
from spacarpy.elements.wheel import (
    Wheel,
    jet_hessians,
    jet_slip,
    jet_slip_dx,
    jet_slip_force_dx,
    jet_state,
    wheel_hessians,
    wheel_reference,
    wheel_reference_problems,
    wheel_slip,
    wheel_slip_dx,
    wheel_slip_force_dx,
    wheel_slips,
    wheel_state,
    wheel_weighted_hessian,
)
from spacarpy.errors import ModelError
from spacarpy.rotation import from_axis_angle, lambda_matrix, rotate, rotation_matrix
from spacarpy.run import run_job

from helpers import deck_errors, fd_columns

KIND = KINDS["WHEEL"]


def quat_mul(a, b):
    a0, av, b0, bv = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([a0 * b0 - np.sum(av * bv, -1, keepdims=True),
                           a0 * bv + b0 * av + np.cross(av, bv)], axis=-1)


def references(n, down=False):
    """Valid references: hubs above the contact points (below for z down), axles tilted by
    a lean theta about the heading x (the C3 disc), radius r."""
    rng = np.random.default_rng(5)
    r = rng.uniform(0.2, 0.5, n)
    theta = rng.uniform(-0.5, 0.5, n)
    a0 = np.stack([np.zeros(n), np.cos(theta), np.sin(theta)], axis=1)
    xq0 = np.concatenate([rng.normal(size=(n, 2)), np.zeros((n, 1))], axis=1)
    xp0 = xq0 + np.stack([np.zeros(n), -r * np.sin(theta), r * np.cos(theta)], axis=1)
    if down:
        xp0[:, 2] *= -1.0
        a0[:, 2] *= -1.0
    return xp0, xq0, a0, r


def random_states(rng, n, spread=0.3):
    xp0, xq0, a0, _ = references(n)
    ref = wheel_reference(xp0, xq0, 3.0 * a0)               # the deck's vector, not unit
    q = from_axis_angle(rng.normal(size=(n, 3)), rng.uniform(-1, 1, n))
    q *= rng.uniform(0.7, 1.3, size=(n, 1))                # |lambda| != 1
    x = np.concatenate([xp0 + spread * rng.normal(size=(n, 3)), q,
                        xq0 + spread * rng.normal(size=(n, 3))], axis=1)
    return x, ref


def test_declarations():
    assert KIND.n_def == 6 and KIND.velocity_modes == (3, 4)
    assert KIND.mode_units == ("m",) * 6 and KIND.rate_units == ("m/s",) * 6
    assert KIND.estiff is None and KIND.em is None and KIND.vector_required


def test_references_are_valid_and_give_zero_deformations():
    for down in (False, True):
        xp0, xq0, a0, r = references(6, down)
        assert wheel_reference_problems(xp0, xq0, a0) == []
        ref = wheel_reference(xp0, xq0, a0)
        np.testing.assert_allclose(ref.e0[:, 2], r, rtol=1e-15)
        assert np.all(ref.n[:, 2] == (-1.0 if down else 1.0))
        x = np.concatenate([xp0, np.tile([1.0, 0, 0, 0], (6, 1)), xq0], axis=1)
        assert np.all(wheel_state(x, ref).e == 0.0)


def test_holonomic_modes_measure_the_contact_points_offsets():
    """Upright wheel, axle y, heading +x (e_l = a x n): moving q by 1 mm along the axle or
    the heading changes mode 1 or 2 by that much; 1 mm down moves it off the rim (mode 3,
    +1 mm) and below the ground (mode 6, -1 mm)."""
    ref = wheel_reference(np.array([[0.0, 0, 0.3]]), np.zeros((1, 3)), np.array([[0.0, 1, 0]]))
    x0 = np.array([[0.0, 0, 0.3, 1, 0, 0, 0, 0, 0, 0]])
    for offset, expected in (((0, 1, 0), (1, 0, 0, 0, 0, 0)), ((1, 0, 0), (0, 1, 0, 0, 0, 0)),
                             ((0, 0, -1), (0, 0, 1, 0, 0, -1))):   # below: off rim and ground
        x = x0.copy()
        x[0, 7:10] += 1e-3 * np.array(offset)
        e = wheel_state(x, ref).e[0]
        expected = 1e-3 * np.array(expected)
        np.testing.assert_allclose(e, expected, atol=1e-17)


def test_jacobian_and_weighted_hessian_equal_central_differences():
    rng = np.random.default_rng(12)
    x, ref = random_states(rng, 6)
    st = wheel_state(x, ref)
    fd = fd_columns(lambda y: wheel_state(y, ref).e, x)
    assert np.abs(fd - st.D).max() <= 1e-7 * np.abs(st.D).max()
    assert np.all(st.D[:, 3:5] == 0.0) and np.all(st.e[:, 3:5] == 0.0)
    w = rng.normal(size=(6, 6))
    fd = fd_columns(lambda y: np.einsum("nk,nkj->nj", w, wheel_state(y, ref).D), x)
    hx = wheel_weighted_hessian(st, w)
    assert np.abs(fd - hx).max() <= 1e-7 * np.abs(hx).max()
    np.testing.assert_allclose(hx, hx.transpose(0, 2, 1), atol=1e-14 * np.abs(hx).max())


def test_slip_kernels_equal_central_differences():
    rng = np.random.default_rng(13)
    x, ref = random_states(rng, 6)
    v = rng.normal(size=x.shape)
    S = wheel_slip(x, ref)
    assert S.shape == (6, 2, 10) and np.all(S[:, :, 7:10] == 0.0)
    # S v is the slip velocity computed directly
    np.testing.assert_allclose(np.einsum("nkj,nj->nk", S, v), wheel_slips(x, v, ref),
                               atol=1e-14 * np.abs(v).max() * 10)
    fd = fd_columns(lambda y: wheel_slips(y, v, ref), x)
    sdx = wheel_slip_dx(x, v, ref)
    assert np.abs(fd - sdx).max() <= 1e-7 * np.abs(sdx).max()
    nu = rng.normal(size=(6, 2))
    fd = fd_columns(lambda y: np.einsum("nkj,nk->nj", wheel_slip(y, ref), nu), x)
    sfx = wheel_slip_force_dx(x, nu, ref)
    assert sfx.shape == (6, 10, 10)
    assert np.abs(fd - sfx).max() <= 1e-7 * np.abs(sfx).max()
    # the kind offers the same kernels
    assert np.array_equal(KIND.slip(x, ref), S)
    assert np.array_equal(KIND.slip_dx(x, v, ref), sdx)
    assert np.array_equal(KIND.slip_force_dx(x, nu, ref), sfx)


def test_closed_form_slip_kernels_equal_the_jet_oracle_to_round_off():
    """The slip kernels are written out in closed form (speed: a bicycle step calls them a
    dozen times); the jet (automatic differentiation, elements/jet.py) gives the same S,
    d(S v)/dx and d(S^T nu)/dx to round-off, at random states with |lambda| != 1, z up
    and z down. A wrong sign or a missing term of the derivation is of order one."""
    rng = np.random.default_rng(29)
    parts = [references(40, down) for down in (False, True)]
    xp0, xq0, a0 = (np.concatenate([p[k] for p in parts]) for k in range(3))
    ref = wheel_reference(xp0, xq0, 3.0 * a0)
    q = from_axis_angle(rng.normal(size=(80, 3)), rng.uniform(-1, 1, 80))
    q *= rng.uniform(0.7, 1.3, size=(80, 1))                 # |lambda| != 1
    x = np.concatenate([xp0 + 0.3 * rng.normal(size=(80, 3)), q,
                        xq0 + 0.3 * rng.normal(size=(80, 3))], axis=1)
    v = rng.normal(size=x.shape)
    nu = rng.normal(size=(80, 2))
    assert (ref.n[:, 2] > 0).sum() == (ref.n[:, 2] < 0).sum() == 40
    for fast, oracle, args in ((wheel_slip, jet_slip, (x, ref)),
                               (wheel_slip_dx, jet_slip_dx, (x, v, ref)),
                               (wheel_slip_force_dx, jet_slip_force_dx, (x, nu, ref))):
        want = oracle(*args)
        got = fast(*args)
        assert got.shape == want.shape
        assert np.abs(got - want).max() <= 1e-14 * np.abs(want).max()
    np.testing.assert_allclose(wheel_slips(x, v, ref),
                               np.einsum("nkj,nj->nk", jet_slip(x, ref), v),
                               rtol=0, atol=1e-14 * np.abs(v).max() * 10)


def test_closed_form_holonomic_modes_equal_the_jet_oracle_to_round_off():
    """Modes 1-3, their Jacobian and their Hessians are written out in closed form (speed:
    a bicycle step evaluates them at every Newton iteration); the first- and second-order
    jets give the same e, D and H to round-off, at random states with |lambda| != 1, z up
    and z down (a wrong term of the quotient rules is of order one), and the states' lazy
    Hessians are these."""
    rng = np.random.default_rng(31)
    parts = [references(30, down) for down in (False, True)]
    xp0, xq0, a0 = (np.concatenate([p[k] for p in parts]) for k in range(3))
    ref = wheel_reference(xp0, xq0, 3.0 * a0)
    q = from_axis_angle(rng.normal(size=(60, 3)), rng.uniform(-1, 1, 60))
    q *= rng.uniform(0.7, 1.3, size=(60, 1))                 # |lambda| != 1
    x = np.concatenate([xp0 + 0.3 * rng.normal(size=(60, 3)), q,
                        xq0 + 0.3 * rng.normal(size=(60, 3))], axis=1)
    st = wheel_state(x, ref)
    e, D = jet_state(x, ref)
    assert np.abs(st.e - e).max() <= 1e-14 * np.abs(e).max()
    assert np.abs(st.D - D).max() <= 1e-14 * np.abs(D).max()
    H = jet_hessians(x, ref)
    assert np.abs(wheel_hessians(x, ref) - H).max() <= 1e-13 * np.abs(H).max()
    np.testing.assert_array_equal(st.H, wheel_hessians(x, ref))


def test_rigid_motion_about_the_vertical_leaves_the_holonomic_modes_unchanged():
    rng = np.random.default_rng(14)
    x, ref = random_states(rng, 8)
    e = wheel_state(x, ref).e
    turn = from_axis_angle(np.tile([0.0, 0, 1], (8, 1)), rng.uniform(-3, 3, 8))
    Q = rotation_matrix(turn)
    shift = np.concatenate([rng.normal(size=(8, 2)), np.zeros((8, 1))], axis=1)
    y = x.copy()
    y[:, 0:3] = np.einsum("nij,nj->ni", Q, x[:, 0:3]) + shift
    y[:, 7:10] = np.einsum("nij,nj->ni", Q, x[:, 7:10]) + shift
    y[:, 3:7] = quat_mul(turn, x[:, 3:7])
    e2 = wheel_state(y, ref).e
    assert np.abs(e2 - e).max() < 1e-14
    assert np.abs(e).max() > 0.01                          # the states are deformed


def rolling_states(rng, n):
    """Wheels in contact (holonomic modes zero) at random lean, heading and spin, with a
    rolling velocity field: any angular velocity, the hub moving so that the rim point at
    the contact stands still."""
    xp0, xq0, a0, r = references(n)
    ref = wheel_reference(xp0, xq0, a0)
    q = quat_mul(from_axis_angle(np.tile([0.0, 0, 1], (n, 1)), rng.uniform(-3, 3, n)),
                 quat_mul(from_axis_angle(np.tile([1.0, 0, 0], (n, 1)),
                                          rng.uniform(-0.5, 0.5, n)),
                          from_axis_angle(a0, rng.uniform(-3, 3, n))))
    a = rotate(q, ref.a0)
    b = np.cross(a, ref.n)
    el = b / np.linalg.norm(b, axis=1, keepdims=True)
    u = np.cross(a, el)
    xq = np.concatenate([rng.normal(size=(n, 2)), np.zeros((n, 1))], axis=1)
    xp = xq - r[:, None] * u
    x = np.concatenate([xp, q, xq], axis=1)
    omega = rng.normal(size=(n, 3))
    qdot = 0.5 * np.einsum("nji,nj->ni", lambda_matrix(q), omega)
    v = np.concatenate([-np.cross(omega, xq - xp), qdot, rng.normal(size=(n, 3))], axis=1)
    return x, v, ref, el


def test_a_rolling_velocity_field_has_no_slip():
    rng = np.random.default_rng(15)
    x, v, ref, el = rolling_states(rng, 8)
    assert np.abs(wheel_state(x, ref).e).max() < 1e-14       # in contact
    s = np.einsum("nkj,nj->nk", wheel_slip(x, ref), v)
    assert np.abs(s).max() < 1e-14
    # sliding the hub along the heading by 1 m/s is a longitudinal slip of 1 m/s
    v[:, 0:3] += el
    np.testing.assert_allclose(np.einsum("nkj,nj->nk", wheel_slip(x, ref), v),
                               np.tile([1.0, 0.0], (8, 1)), atol=1e-14)


# ---------------------------------------------------------------------------- the deck
WHEEL = """X 1 {hub}
X 2 {contact}
WHEEL 5 1 3 2 {axle}
{extra}END
HALT
XM 1 2.0
XM 3 0.045 0 0 0.09 0 0.045
GRAVITY 0 0 -9.81
{data}END
END
"""


def wheel_deck(hub="0 0 0.3", contact="0 0 0", axle="0 1 0", extra="", data=""):
    return WHEEL.format(hub=hub, contact=contact, axle=axle, extra=extra, data=data)


@pytest.mark.parametrize("hub,contact,axle,message", [
    ("0 0 0.3", "0 0.1 0", "0 1 0", "WHEEL 5: the contact node is not in the wheel plane: the "
     "hub-to-contact vector has 0.1 m along the axle (0, 1, 0)"),
    ("0 0 0.3", "0.1 0 0", "0 1 0", "WHEEL 5: the contact node is not the rim point nearest "
     "the ground: the hub-to-contact vector (0.1, 0, -0.3) must point along (0, 0, -1), the "
     "wheel plane's direction towards the ground"),
    ("0 0 0.3", "0 0 0", "0 0 1", "WHEEL 5: the axle (0, 0, 1) is vertical: the wheel would "
     "lie flat on the ground"),
    ("0 0 0", "0.3 0 0", "0 1 0", "WHEEL 5: the contact node is level with the hub: the "
     "ground is the horizontal plane through the contact node, so the hub must be above or "
     "below it in z"),
    ("0 0 0.3", "0 0 0", "0 0 0", "element 5: the axle (0, 0, 0) is (nearly) zero"),
])
def test_reference_errors_name_the_wheel_line(hub, contact, axle, message):
    assert deck_errors(wheel_deck(hub, contact, axle)) == [(3, message)]


def test_em_dyne_estiff_and_a_missing_axle_are_deck_errors():
    assert deck_errors(wheel_deck(data="EM 5 1.0\n")) == [
        (9, "EM 5: a WHEEL has no mass of its own; put masses and inertias on its nodes "
            "with XM")]
    assert deck_errors(wheel_deck(extra="DYNE 5 4\n")) == [
        (4, "DYNE 5: a WHEEL mode cannot be flexible: tyre compliance is not supported yet "
            "(WHEEL modes are rigid, or released with RLSE)")]
    assert deck_errors(wheel_deck(data="ESTIFF 5 1e5\n")) == [
        (9, "ESTIFF 5: a WHEEL takes no stiffness: tyre compliance is not supported yet")]
    errors = deck_errors(wheel_deck(axle=""))
    assert len(errors) == 1 and errors[0][1].startswith("WHEEL takes exactly 7 fields")


def test_a_slip_cannot_be_prescribed():
    assert deck_errors(wheel_deck(extra="INPUTE 5 4\n", data="INPUTE 5 4 0.0\n")) == [
        (4, "INPUTE: deformation 4 of WHEEL 5 is a slip (a velocity-level constraint): "
            "prescribing it is not supported yet")]


def test_held_slips_are_no_holonomic_constraints():
    """A free disc has 5 configuration degrees of freedom (x, y, heading, lean, spin): the
    holonomic modes 1, 2, 3, 6 and one Euler normalization constrain its 10 coordinates, the
    held slips do not (they are velocity-level constraints)."""
    from spacarpy.numbering import number_model
    model = job_from_text(wheel_deck()).model
    num = number_model(model)
    assert num.n_rigid == 4 and num.n_unknown - num.n_constraint == 5
    assert list(num.groups[0].rigid_mode) == [0, 1, 2, 5]


def test_a_z_down_wheel_and_released_slips_build():
    job = job_from_text(wheel_deck(hub="0 0 -0.3", extra="RLSE 5 4 5\n"))
    es = job.model.elements["WHEEL"]
    assert es.def_class.tolist() == [[0, 0, 0, 2, 2, 0]]


@pytest.mark.parametrize("mode,extra", [(10, "RLSE 5 4 5\n"), (7, "RLSE 5 4 5\n"),
                                        (1, "RLSE 5 4 5\n")])
def test_every_analysis_refuses_a_wheel_cleanly(tmp_path, capsys, mode, extra):
    """Released slips would leave the stored accumulated slip unintegrated: one line, exit 3
    (a model error), no file. (Held slips run in statics, the linearizations at rest and the
    transient: tests/test_rolling_static.py, tests/test_rolling_transient.py; mode 0 reports
    them: tests/test_kinematic_coords.py.)"""
    deck = tmp_path / "wheel.dat"
    deck.write_text(wheel_deck(extra=extra, data="TIMESTEP 1 10\n"))
    out = tmp_path / "wheel.h5"
    assert main(["run", str(deck), "-o", str(out), "--mode", str(mode), "-q"]) == 3
    err = capsys.readouterr().err
    assert "Traceback" not in err and not out.exists()
    if extra:
        assert "WHEEL elements are not supported in MODE" in err
        assert "no solver integrates the released slips (modes 4 5) of WHEEL 5" in err
    else:
        assert "WHEEL slips (non-holonomic constraints) are not supported in MODE" in err
        assert "(WHEEL 5 modes 4 5 are held: rolling without slip)" in err
    if extra:          # released slips: refused in the deck's own (static) analysis too
        job = job_from_text(deck.read_text())
        with pytest.raises(ModelError, match="not supported in MODE"):
            run_job(job, tmp_path / "api.h5")


def test_the_run_time_check_stops_a_wheel_lying_flat():
    """The kind's check names the first element whose axle has turned vertical."""
    xp0, xq0, a0, _ = references(3)
    ref = wheel_reference(xp0, xq0, a0)
    q = np.tile([1.0, 0, 0, 0], (3, 1))
    x = np.concatenate([xp0, q, xq0], axis=1)
    assert KIND.check(wheel_state(x, ref), ref) is None
    # turn wheel 1 so that its axle points up (the lean angle plus 90 degrees about x)
    lean = np.arctan2(a0[1, 2], a0[1, 1])
    x[1, 3:7] = from_axis_angle(np.array([1.0, 0, 0]), np.array(np.pi / 2 - lean))
    row, message = KIND.check(wheel_state(x, ref), ref)
    assert row == 1 and "axle has turned vertical" in message
    assert isinstance(KIND, Wheel)
