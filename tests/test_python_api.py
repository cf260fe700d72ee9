"""The Python API of issue 35: ModelBuilder for every keyword, run() in memory with progress,
and the result views' reprs, to_xarray() and to_dataframe().

docs/python.md's two scripts (the leaf-spring guidance and the slider-crank) are run as they
stand and compared, dataset by dataset, with the runs of their decks in decks/.
"""
from __future__ import annotations

import inspect
import math
import re
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy import ModelBuilder
from spacarpy.deck import job_from_text, load
from spacarpy.deck.api_keywords import KEYWORD_METHODS
from spacarpy.deck.keywords import KEYWORDS
from spacarpy.errors import DeckError
from spacarpy.results.in_memory import InMemoryResults
from spacarpy.results.labelled import MissingExtraError
from spacarpy.run import run_job

ROOT = Path(__file__).resolve().parents[1]
DOCS = (ROOT / "docs" / "python.md").read_text()
BLOCKS = re.findall(r"```python\n(.*?)```", DOCS, re.S)


def _datasets(source) -> dict:
    """Every dataset of a results file (a path, or the image of InMemoryResults)."""
    out = {}
    with h5py.File(source, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()]
        f.visititems(visit)
    return out


def _assert_same_results(deck_file, python_results: InMemoryResults | str):
    """Every dataset of the two runs agrees to 1e-12 (relative to the dataset's largest
    value); only /deck (the text) differs. Returns the number of datasets compared."""
    import io
    a = _datasets(deck_file)
    b = _datasets(io.BytesIO(python_results._image)
                  if isinstance(python_results, InMemoryResults) else python_results)
    assert set(a) == set(b)
    compared = 0
    for name, x in a.items():
        y = b[name]
        if name == "deck":
            continue
        compared += 1
        if isinstance(x, np.ndarray) and x.dtype.kind in "fc":
            assert x.shape == y.shape, name
            scale = max(float(np.nanmax(np.abs(x), initial=0.0)), 1e-300)
            assert np.array_equal(np.isnan(x), np.isnan(y)), name
            diff = np.abs(np.nan_to_num(x - y, nan=0.0, posinf=0.0, neginf=0.0))
            assert np.all(np.isinf(x) == np.isinf(y)), name
            assert float(np.max(diff, initial=0.0)) <= 1e-12 * scale, name
        elif isinstance(x, np.ndarray):
            assert np.array_equal(x, y), name
        else:
            assert x == y, name
    return compared


@pytest.fixture(scope="module")
def guidance():
    """docs/python.md's leaf-spring guidance script, run (in memory)."""
    ns: dict = {}
    exec(compile(BLOCKS[0], "docs/python.md:leaf-spring", "exec"), ns)
    return ns


def test_docs_leafspring_guidance_equals_its_deck(guidance, tmp_path):
    deck = tmp_path / "deck.h5"
    run_job(load(ROOT / "decks" / "leafspring_guidance_buckling.dat"), deck)
    res = guidance["res"]
    assert isinstance(res, InMemoryResults) and res.completed
    assert _assert_same_results(deck, res) > 40
    # the number the deck's header and EXPECT line give (the critical torque, to 1e-5)
    assert guidance["critical_torque"] == pytest.approx(0.308317, rel=1e-5)


def _slider_crank_builder():
    code, sep, _ = BLOCKS[1].partition("\n\n\nres = ")
    assert sep, "docs/python.md's slider-crank block ends with 'res = slider_crank().run()'"
    ns: dict = {}
    exec(compile(code, "docs/python.md:slider-crank", "exec"), ns)
    return ns["slider_crank"]


def _slider_crank_deck(t_end, n_steps) -> str:
    text = (ROOT / "decks" / "slider_crank_flexible.dat").read_text()
    assert "TIMESTEP 0.2 200" in text
    return text.replace("TIMESTEP 0.2 200", f"TIMESTEP {t_end!r} {n_steps}")


def test_docs_slider_crank_equals_its_deck_over_20_steps(tmp_path):
    deck = tmp_path / "deck.h5"
    run_job(job_from_text(_slider_crank_deck(0.02, 20), "slider_crank.dat"), deck)
    res = _slider_crank_builder()(0.02, 20).run()
    assert res.transient.n_step == 21
    assert _assert_same_results(deck, res) > 40
    # the crank pin A moves on its circle: |x_A| = r at every stored time
    a = res.transient.position(node=3)
    np.testing.assert_allclose(np.linalg.norm(a[:, :2], axis=1), 0.15, rtol=1e-12)


@pytest.mark.slow
def test_docs_slider_crank_equals_its_deck_over_its_whole_span(tmp_path):
    deck = tmp_path / "deck.h5"
    run_job(load(ROOT / "decks" / "slider_crank_flexible.dat"), deck)
    out = tmp_path / "python.h5"
    res = _slider_crank_builder()().run(out)
    assert res.path == str(out) and res.transient.n_step == 201
    assert _assert_same_results(deck, str(out)) > 40


# ------------------------------------------------------------------ a transient, in Python

def _pendulum(n_steps=440, t_end=2.2):
    """A uniform rigid rod (L = 1 m, 2 kg) released from the horizontal on a free hinge
    (decks/pendulum_rigid_90deg.dat, built in Python)."""
    return (ModelBuilder("rigid pendulum").mode("transient").rhoinf(1)
            .x(1, 0, 0, 0).x(3, 1.0, 0, 0)
            .rbeam(1, 1, 4, 3, (0, 1, 0))
            .hinge(10, 2, 4, (0, 0, 1)).rlse(10, 1)
            .fix(1).fix(2)
            .em(1, 2.0).gravity(0, -9.81, 0).timestep(t_end, n_steps))


def test_a_transient_built_in_python_swings_with_the_exact_period_and_reports_progress():
    calls = []
    # a quarter period and a bit, in steps of 5 ms
    res = _pendulum(110, 0.55).run(progress=lambda done, total: calls.append((done, total)))
    tr = res.transient
    assert tr.n_step == 111 and res.summary.n_time == 111
    # exact quarter period: T/4 = sqrt(I / (m g d)) K(k^2 = 1/2), I = m L^2/3, d = L/2
    k_half = 1.8540746773013719
    quarter = math.sqrt((1 / 3) / (9.81 / 2)) * k_half
    x = tr.position(node=3)[:, 0]
    i = int(np.flatnonzero(x < 0)[0])
    t = tr.time
    crossing = t[i - 1] + (t[i] - t[i - 1]) * x[i - 1] / (x[i - 1] - x[i])
    assert crossing == pytest.approx(quarter, abs=5e-5)          # h = 5 ms: 1e-5 s off
    assert np.max(np.abs(tr.energy_balance)) < 1e-4 * 9.81        # of m g L/2 = 9.81 J
    # progress: after every time step, (time reached, end time), ending at the end
    assert len(calls) == 110 and calls[-1] == (pytest.approx(0.55), 0.55)
    assert all(b == 0.55 for _, b in calls)
    assert np.all(np.diff([a for a, _ in calls]) > 0)


def test_progress_of_a_static_path_is_called_per_load_step():
    calls = []
    res = (ModelBuilder().x(1, 0, 0, 0).x(3, 1.0, 0, 0)
           .beams(1, 1, 2, 3, 4, 4).dyne(range(1, 5), 1, 2, 3, 4, 5, 6).fix(1).fix(2)
           .estiff(range(1, 5), 1e7, 1e3, 1e3, 1e3).delxf(3, 0, 0, 1.0)
           .iterstep(20, 5, 1e-10)
           .run(progress=lambda done, total: calls.append((done, total))))
    assert calls == [(k, 5) for k in range(6)]
    # the tip deflection of the cantilever under 1 N: P L^3 / (3 EI) = 1/3000 m (small)
    assert res.static.displacement(node=3, step=-1)[2] == pytest.approx(1 / 3000, rel=1e-3)


def test_run_writes_the_file_when_asked_and_the_memory_image_equals_it(tmp_path):
    out = tmp_path / "p.h5"
    on_disk = _pendulum(20).run(out)
    in_memory = _pendulum(20).run()
    assert on_disk.path == str(out) and in_memory.path.startswith("<memory")
    copy = tmp_path / "copy.h5"
    in_memory.write(copy)
    assert _assert_same_results(out, str(copy)) > 10
    np.testing.assert_array_equal(on_disk.transient.position(), in_memory.transient.position())


# ------------------------------------------------------------------ the keyword methods

def test_every_supported_keyword_has_a_method_with_a_real_signature():
    skipped = {"END", "HALT", "VISUALIZATION", "INCLUDE", "EXPECT"}
    for name, spec in KEYWORDS.items():
        if not spec.supported or name in skipped:
            assert name not in KEYWORD_METHODS
            continue
        method = getattr(ModelBuilder, name.lower())
        params = list(inspect.signature(method).parameters)
        assert params[0] == "self" and len(params) >= 1 + (len(spec.required) > 0), name
        assert spec.name in (method.__doc__ or ""), name
    for kind in ("hinge", "rbeam", "truss", "plbeam", "pltruss", "plhinge", "pinbody",
                 "wheel", "beamw", "beamc", "estiff", "stiffness", "gravity", "timestep",
                 "inputx", "outx", "cross_section"):
        assert callable(getattr(ModelBuilder, kind))
    assert str(inspect.signature(ModelBuilder.hinge)) == "(self, e, r, s, axis=None)"
    assert str(inspect.signature(ModelBuilder.wheel)) == "(self, e, p, r, q, axis)"


@pytest.mark.parametrize("call, message", [
    (lambda mb: mb.hinge(2.5, 1, 2),
     "ModelBuilder.hinge(): e (element number) must be a whole number, got 2.5"),
    (lambda mb: mb.truss(1, 0, 2),
     "ModelBuilder.truss(): p (position node p) must be 1 or more, got 0"),
    (lambda mb: mb.rhoinf(1.5),
     "ModelBuilder.rhoinf(): rho_inf (spectral radius at infinite frequency) must be in "
     "[0, 1], got 1.5"),
    (lambda mb: mb.deformations("bent"),
     "ModelBuilder.deformations(): variant (deformation variant (basic or modified)) must "
     "be one of modified, basic, got 'bent'"),
    (lambda mb: mb.hinge(1, 2, 4, (0, 1)),
     "ModelBuilder.hinge(): axis must be 3 numbers (ax, ay, az), got 2"),
    (lambda mb: mb.gravity(0, "down", 0),
     "ModelBuilder.gravity(): gy (y component of gravity (m/s^2)) must be a number, got "
     "'down'"),
    (lambda mb: mb.estiff([], 1.0),
     "ModelBuilder.estiff(): e (element number) selects no element"),
    (lambda mb: mb.xf(3, 1.0, None, 2.0),
     "ModelBuilder.xf(): f3 needs f2 (the fields are positional: XF n f1 [f2] [f3])"),
    (lambda mb: mb.timestep(1.0),
     "ModelBuilder.timestep(): missing a required argument: 'n_steps' (usage: TIMESTEP "
     "t_end n_steps)"),
    (lambda mb: mb.cross_section(1, "HEX", 0.01),
     "ModelBuilder.cross_section(): shape must be RECT or CIRC, got 'HEX'"),
])
def test_arguments_are_checked_at_the_call_naming_method_and_argument(call, message):
    mb = ModelBuilder()
    line = inspect.currentframe().f_lineno + 2
    with pytest.raises(DeckError) as info:
        call(mb)
    ((loc, msg, _),) = info.value.items
    assert msg == message
    # located at the script line of the call: the parametrized lambda's line
    method = message.split("(")[0].split(".")[1]
    assert loc.file == __file__ and loc.line != line
    assert f"lambda mb: mb.{method}(" in Path(__file__).read_text().splitlines()[loc.line - 1]


def test_a_script_covers_the_modules_signals_and_visualization():
    mb = (ModelBuilder().mode("state_space").x(1, 0, 0, 0).x(3, 1.0, 0, 0)
          .beam(1, 1, 2, 3, 4, (0, 1, 0)).dyne(1, 1, 2, 3, 4, 5, 6).fix(1).fix(2)
          .estiff(1, 1e7, 1e3, 1e3, 1e3).em(1, 1.0, 1e-4, 5e-5, 5e-5)
          .xf(3, 0, -1.0, 0).iterstep(20, 1, 1e-10).damping(0.0, 1e-4)
          .inputf(1, 3, 2).outx(1, 3, 2).outxp(2, 3, 2)
          .cross_section(1, "RECT", 0.02, 0.01))
    deck = mb.to_deck()
    modules = deck.split("END\nHALT\n")
    assert len(modules) == 3 and modules[2].startswith("INPUTF 1 3 2\nOUTX 1 3 2")
    assert deck.endswith("END\nEND\nVISUALIZATION\nBEAMPROPS 1\nCROSSTYPE RECT\n"
                         "CROSSDIM 0.02 0.01\n")
    res = mb.run()
    ss = res.state_space
    assert ss.input_name == ["INPUTF 1 3 2"] and len(ss.output_name) == 2
    # the static stiffness of the tip along y: 3 EI / L^3 = 3000 N/m, so the DC gain of
    # OUTX (y of node 3) to INPUTF (a y force on node 3) is 1/3000 m/N
    m = ss.matrices()
    gain = (m["D"] - m["C"] @ np.linalg.solve(m["A"], m["B"]))[0, 0]
    assert gain == pytest.approx(1 / 3000, rel=1e-6)
    assert res.model.cross_section_type[0] == "RECT"


def test_inputx_with_a_value_writes_both_modules():
    mb = ModelBuilder().x(1, 0, 0).x(3, 1.0, 0).plbeam(1, 1, 2, 3, 4).fix(1)
    mb.inputx(2, 1, value=0.1, velocity=2.0)
    deck = mb.to_deck()
    kin, data = deck.split("END\nHALT\n")
    assert "INPUTX 2 1\n" in kin and "INPUTX 2 1 0.1 2.0\n" in data
    with pytest.raises(DeckError, match=r"ModelBuilder.inputx\(\): value needs exactly one"):
        ModelBuilder().inputx(2, 1, 2, value=0.1)


# ------------------------------------------------------------------ reprs and labelled data

def test_reprs_name_the_group_sizes_and_units(guidance):
    res = guidance["res"]
    text = repr(res.static)
    assert text.startswith("<StaticView /static of '<memory")
    assert "steps  2 (0 = the initial state), load factor 0 to 1" in text
    assert "23 position" in text and "22 orientation" in text
    assert "BEAM   20 elements, 6 modes (deformation: m; stress resultant: N)" in text
    assert "HINGE  1 elements" in text and "N m" in text
    assert "critical load multiplier  30.83" in repr(res.buckling)
    assert "<table>" in res.static._repr_html_() and "HINGE" in res.static._repr_html_()
    assert "critical load multiplier" in res.buckling._repr_html_()
    assert repr(res.model) == ("<ModelView /model: 23 position nodes, 22 orientation nodes; "
                               "elements BEAM 20, HINGE 1, RBEAM 2>")
    assert res.model._repr_html_() == ("<div><code>&lt;ModelView /model: 23 position nodes, "
                                       "22 orientation nodes; elements BEAM 20, HINGE 1, "
                                       "RBEAM 2&gt;</code></div>")


def test_to_xarray_and_to_dataframe_of_static_and_buckling(guidance):
    res = guidance["res"]
    st = res.static
    ds = st.to_xarray()
    np.testing.assert_array_equal(ds["load_factor"].values, st.load_factor)
    np.testing.assert_array_equal(ds["position_node"].values, res.model.position_nodes)
    np.testing.assert_array_equal(ds["BEAM_element"].values, np.arange(1, 21))
    np.testing.assert_array_equal(ds["HINGE_element"].values, [23])
    np.testing.assert_array_equal(ds.position.sel(position_node=9).values,
                                  st.position(node=9))
    np.testing.assert_array_equal(ds.HINGE_stress_resultant.sel(HINGE_element=23).values,
                                  st.stress_resultant(element=23, kind="HINGE"))
    assert ds.position.attrs["units"] == "m" and ds.BEAM_stress_resultant.attrs["units"] == "N"
    assert "units" not in ds.HINGE_deformation.attrs
    assert list(ds["HINGE_mode_units"].values) == ["rad", "1", "1"]
    assert list(ds["reaction_units"].values[:3]) == ["N", "N", "N"]
    # the hinge turns freely (RLSE 23 1): its mode 1 carries no torque, exactly
    assert float(ds.HINGE_stress_resultant.sel(HINGE_element=23).isel(step=-1,
                                                                      HINGE_mode=0)) == 0.0
    df = st.to_dataframe()
    assert df.index.names == ["step", "node"] and len(df) == 2 * 23
    assert df.loc[(1, 9), "uz"] == st.displacement(node=9, step=1)[2]
    assert df.attrs["units"]["ux"] == "m"
    el = st.to_dataframe("elements", kind="HINGE")
    assert list(el.columns) == ["e1", "e2", "e3", "s1", "s2", "s3"]
    assert el.attrs["units"]["e1"] == "rad" and el.attrs["units"]["s1"] == "N m"
    bk = res.buckling.to_xarray()
    np.testing.assert_array_equal(bk["mode"].values, [1, 2, 3])
    assert float(bk.critical_load_multiplier[-1]) == res.buckling.critical_load_multiplier[-1]
    np.testing.assert_array_equal(bk.shape_position.isel(linearized_step=-1, mode=0).values,
                                  res.buckling.shape(1).position)
    bdf = res.buckling.to_dataframe()
    assert bdf.loc[(0, 1), "load_multiplier"] == res.buckling.load_multiplier[0, 0]
    with pytest.raises(ValueError, match="what must be one of modes"):
        res.buckling.to_dataframe("nodes")


def test_to_xarray_of_a_transient_and_of_eigen():
    res = _pendulum(40).modes(2).run()
    tr = res.transient
    ds = tr.to_xarray()
    np.testing.assert_array_equal(ds["time"].values, tr.time)
    assert ds.time.attrs["units"] == "s" and ds.kinetic_energy.attrs["units"] == "J"
    np.testing.assert_array_equal(ds.velocity.sel(position_node=3).values,
                                  tr.velocity(node=3))
    np.testing.assert_array_equal(ds.RBEAM_stress_resultant.values, tr.stress_resultant(
        kind="RBEAM"))
    df = tr.to_dataframe("steps")
    assert df.index.name == "time" and df.attrs["units"]["energy_balance"] == "J"
    np.testing.assert_array_equal(df["kinetic_energy"].values, tr.kinetic_energy)
    # eigen: a cantilever (L = 1 m, EI = 1e3 N m^2, rhoA = 1 kg/m, 8 beams), whose first
    # bending frequency is 1.8751^2 / (2 pi) sqrt(EI / (rhoA L^4)) = 17.696 Hz
    eig = (ModelBuilder().mode("eigen").modes(3).x(1, 0, 0, 0).x(3, 1.0, 0, 0)
           .beams(1, 1, 2, 3, 4, 8).dyne(range(1, 9), 1, 2, 3, 4, 5, 6).fix(1).fix(2)
           .estiff(range(1, 9), 1e7, 1e3, 1e3, 1e3).em(range(1, 9), 1.0)
           .iterstep(10, 1, 1e-10).run().eigen)
    ed = eig.to_xarray()
    np.testing.assert_array_equal(ed.frequency.values, eig.frequency)
    assert ed.frequency.attrs["units"] == "Hz"
    np.testing.assert_array_equal(ed["mode"].values, [1, 2, 3])
    assert float(ed.frequency.isel(linearized_step=-1, mode=0)) == pytest.approx(
        1.8751040687**2 / (2 * math.pi) * math.sqrt(1e3), rel=2e-3)
    np.testing.assert_array_equal(ed.shape_position.isel(linearized_step=-1, mode=1).values,
                                  eig.shape(2).position)
    assert ed.shape_position.attrs["units"] == "m"     # phi^T M phi = 1 kg m^2 (schema 3.0)
    assert re.search(r"frequency +Hz; last linearization: 17\.6959, 17\.6959, ", repr(eig))
    edf = eig.to_dataframe()
    assert edf.loc[(0, 2), "frequency"] == eig.frequency[0, 1]


def test_labelled_data_without_the_extra_says_how_to_install_it(guidance, monkeypatch):
    monkeypatch.setitem(sys.modules, "xarray", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'spacarpy\[xarray\]'"):
        guidance["res"].static.to_xarray()


def test_compliance_view_is_labelled_and_equals_the_file(result_files):
    """/compliance: repr, notebook repr, to_xarray() and to_dataframe() labelled by response
    and load component, the values those of the HDF5 datasets."""
    from spacarpy.results import open_results

    path = result_files["column"]
    with h5py.File(path, "r") as f, open_results(path) as res:
        comp = res.compliance
        text = repr(comp)
        assert text.startswith("<ComplianceView /compliance of ")
        assert "node            position 3, orientation 4" in text
        assert "m/N, 1/N, rad/N, rad/(N m)" in text
        assert "<table>" in comp._repr_html_() and "rad/(N m)" in comp._repr_html_()
        ds = comp.to_xarray()
        for name in ("global", "local"):
            np.testing.assert_array_equal(ds[name].values, f[f"compliance/{name}"][...])
        assert ds["response"].values.tolist() == [
            s.decode() for s in f["compliance/response"][...]]
        assert ds["load_component"].values.tolist() == [
            s.decode() for s in f["compliance/load_component"][...]]
        assert ds["compliance_units"].values.ravel().tolist() == [
            str(u) for u in f["compliance/global"].attrs["units_per_index"]]
        assert float(ds["global"].sel(response="uy", load_component="Tz").isel(
            linearized_step=2)) == f["compliance/global"][2, 1, 5]
        np.testing.assert_array_equal(ds["step"].values, f["compliance/step"][...])
        df = comp.to_dataframe("local")
        assert df.loc[(3, "phiz"), "Tz"] == f["compliance/local"][3, 5, 5]
        assert list(df.columns) == ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"]
        assert df.attrs["units"][("ux", "Tx")] == "1/N"
        assert df.attrs["units"][("phix", "Tx")] == "rad/(N m)"
        with pytest.raises(ValueError, match="global, local"):
            comp.to_dataframe("modes")


def test_state_space_view_is_labelled_and_equals_the_file(result_files):
    """/state_space: A, B, C, D and the poles labelled by the state, input and output
    names, equal to the HDF5 datasets."""
    from spacarpy.results import open_results

    path = result_files["state_space"]
    with h5py.File(path, "r") as f, open_results(path) as res:
        ss = res.state_space
        text = repr(ss)
        assert text.startswith("<StateSpaceView /state_space of ")
        assert "inputs          2: INPUTF 1 9 2, INPUTF 2 9 3" in text
        assert re.search(r"states +48: BEAM 1 mode 1, ", text)
        assert "poles           1/s; last linearization: " in text
        assert "OUTE 4 1 3" in ss._repr_html_()
        ds = ss.to_xarray()
        for name in ("A", "B", "C", "D", "pole"):
            np.testing.assert_array_equal(ds[name].values, f[f"state_space/{name}"][...])
        states = [s.decode() if isinstance(s, bytes) else s
                  for s in f["state_space/state_name"][...]]
        assert ds["state"].values.tolist() == states == ds["state_column"].values.tolist()
        assert ds["system_input"].values.tolist() == ss.input_name
        assert ds["system_output"].values.tolist() == ss.output_name
        k = states.index("rate of BEAM 2 mode 3")
        assert float(ds.A.sel(state=states[3], state_column=states[k]).isel(
            linearized_step=-1)) == f["state_space/A"][-1, 3, k]
        assert ds.pole.attrs["units"] == f["state_space/pole"].attrs["units"] == "s^-1"
        df = ss.to_dataframe("C")
        assert df.loc[(2, "OUTE 4 1 3"), states[5]] == f["state_space/C"][2, 3, 5]
        assert df.shape == (3 * 5, 48) and df.attrs["units"] == "1"
        with pytest.raises(ValueError, match="A, B, C, D"):
            ss.to_dataframe("E")


def test_labelled_units_are_the_schema_units(result_files):
    """The units of the eigen and buckling variables in to_xarray() and to_dataframe() are
    those the file stores (labelled.py reads them from the schema: they cannot drift)."""
    from spacarpy.results import open_results
    from spacarpy.results.schema import DATASETS

    path = result_files["column"]
    with h5py.File(path, "r") as f, open_results(path) as res:
        for group, names in (("eigen", ("frequency", "eigenvalue_real", "eigenvalue_imag",
                                        "shape_position", "shape_euler")),
                             ("buckling", ("load_multiplier", "critical_load_multiplier",
                                           "shape_position", "shape_euler"))):
            ds = getattr(res, group).to_xarray()
            units = getattr(res, group).to_dataframe().attrs["units"]
            for name in names:
                stored = f[f"{group}/{name}"].attrs["units"]
                assert ds[name].attrs["units"] == stored == DATASETS[f"{group}/{name}"].units
                if name in units:
                    assert units[name] == stored, (group, name)
        assert "positions: m, Euler parameters: 1" in repr(res.eigen)
