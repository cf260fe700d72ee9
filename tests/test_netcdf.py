"""Result and sweep files open in the netCDF world (schema 3.0, docs/results.md "netCDF").

Every group of every result file of the session's fixtures (each analysis and element kind)
and of a sweep file opens with xarray (engines h5netcdf and netcdf4, and as a DataTree),
with netCDF4-python and with ``ncdump -h`` where installed, without a warning; every
``units`` attribute (and every entry of a ``units_per_index`` companion) parses with pint
into the dimension the schema documents, and with UDUNITS2 where it is installed.
"""
from __future__ import annotations

import re
import shutil
import subprocess
import warnings

import h5py
import numpy as np
import pytest

xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")
netCDF4 = pytest.importorskip("netCDF4")
pint = pytest.importorskip("pint")
try:                        # UDUNITS2 (bundled in cf-units' wheels, where the platform has one)
    import cf_units
except ImportError:         # pragma: no cover - platforms without a cf-units wheel
    cf_units = None
UDUNITS2_MISSING = "cf_units (UDUNITS2) not importable: no cf-units wheel for this platform"

from spacarpy.results.schema import DATASETS  # noqa: E402

UREG = pint.UnitRegistry()
#: Completed result files of conftest.result_files (the partial ones are SWMR files that a
#: writer may still hold; they are checked by the validator, not here).
KEYS = ("bend", "frame", "column", "fourbar", "truss", "driven", "planar", "pltruss",
        "transient", "state_space", "arclength", "bicycle", "inverse", "truss_dyn",
        "planar_dyn", "pltruss_dyn", "pinbody", "pinbody_dyn", "dynx", "beamw", "beamw_dyn",
        "beamc", "beamc_dyn", "wheel")

#: Dimensions of units, independent of the schema's strings: a wrong unit string fails.
FORCE, LENGTH = UREG.N.dimensionality, UREG.m.dimensionality
EXPECTED = {
    "static/position": LENGTH, "transient/velocity": (UREG.m / UREG.s).dimensionality,
    "eigen/frequency": (1 / UREG.s).dimensionality,
    "eigen/eigenvalue_real": (1 / UREG.s ** 2).dimensionality,
    "eigen/shape_position": LENGTH, "transient/kinetic_energy": UREG.J.dimensionality,
    "static/elements/BEAM/stress_resultant": FORCE,
    "static/elements/BEAM/max_von_mises_stress": UREG.Pa.dimensionality,
    "state_space/pole": (1 / UREG.s).dimensionality,
}
#: The same for the entries of a units_per_index companion.
EXPECTED_PER_INDEX = {
    "model/elements/BEAM/stiffness": [FORCE] + [(UREG.N * UREG.m ** 2).dimensionality] * 3
    + [(UREG.m ** 2).dimensionality] * 2,
    "static/elements/HINGE/deformation": [UREG.dimensionless.dimensionality] * 3,
    "compliance/global": [(UREG.m / UREG.N).dimensionality] * 3
    + [(1 / UREG.N).dimensionality] * 3,             # the first row: dx per F, then per T
}


def _groups(path) -> list:
    groups = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: groups.append(name)
                     if isinstance(obj, h5py.Group) else None)
    return [None] + groups


def _open_everywhere(path) -> None:
    """Every group with both engines, the DataTree, netCDF4-python: no error, no warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for group in _groups(path):
            for engine in ("h5netcdf", "netcdf4"):
                with xr.open_dataset(path, group=group, engine=engine) as ds:
                    ds.load()
                    for name, var in ds.variables.items():     # every axis is named
                        assert not any(d.startswith("phony_dim") for d in var.dims), \
                            (path, group, name, var.dims)
        for engine in ("h5netcdf", "netcdf4"):
            tree = xr.open_datatree(path, engine=engine)
            tree.load()
            tree.close()
        with netCDF4.Dataset(path) as nc:
            def walk(g):
                for var in g.variables.values():
                    var.set_auto_mask(False)
                    var[...]
                for child in g.groups.values():
                    walk(child)
            walk(nc)


def open_headers(path) -> None:
    """Every group of ``path`` with both xarray engines, without loading the data: no error,
    no warning, every axis named (what the batch test checks on every shipped deck's
    result, where :func:`_open_everywhere` on all of them would take minutes)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for group in _groups(path):
            for engine in ("h5netcdf", "netcdf4"):
                with xr.open_dataset(path, group=group, engine=engine) as ds:
                    for name, var in ds.variables.items():
                        assert not any(d.startswith("phony_dim") for d in var.dims), \
                            (path, group, name, var.dims)


def check_units(path) -> None:
    """Every ``units`` (and ``units_per_index`` entry) of ``path`` parses with pint into the
    dimension of the schema's unit, and with UDUNITS2 into the same one where cf_units
    imports (public name of :func:`_check_units`)."""
    _check_units(path, udunits2=cf_units is not None)


def _units(path) -> dict:
    """{dataset: (units, units_per_index or None, dims of the index)}."""
    out = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset):
            per = obj.attrs.get("units_per_index")
            out[name] = (obj.attrs["units"], None if per is None else [
                u.decode() if isinstance(u, bytes) else str(u) for u in per],
                obj.attrs.get("units_per_index_dims"))
    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return out


def _parse(unit: str):
    return UREG("1").units if unit == "1" else UREG.parse_units(unit)


#: SI base unit of each pint base dimension: a pint dimensionality as a UDUNITS2 string.
_SI_BASE = {"[length]": "m", "[mass]": "kg", "[time]": "s", "[current]": "A",
            "[temperature]": "K", "[substance]": "mol", "[luminosity]": "cd"}


def _si_string(dimensionality) -> str:
    """``{'[length]': 1, '[time]': -2}`` -> ``"m^1 s^-2"`` (``"1"`` when dimensionless).
    UDUNITS2 has no fractional powers (it reads ``kg^0.5`` as ``kg^0`` times 5, silently):
    a dimension with one fails here."""
    assert all(float(p).is_integer() for p in dict(dimensionality).values()), \
        f"UDUNITS2 has no half powers: {dict(dimensionality)}"
    parts = [f"{_SI_BASE[d]}^{p:g}" for d, p in sorted(dict(dimensionality).items())]
    return " ".join(parts) or "1"


def _check_udunits2(name: str, unit: str, dimensionality) -> None:
    """``unit`` parses with UDUNITS2 (cf_units) and has the dimension ``dimensionality``
    (pint's, already compared with the documented one): both SI base strings are
    convertible into each other, and a unit of another dimension is not."""
    try:
        parsed = cf_units.Unit(unit)
    except ValueError as exc:
        raise AssertionError(f"{name}: UDUNITS2 cannot parse {unit!r}: {exc}") from None
    want = cf_units.Unit(_si_string(dimensionality))
    assert parsed.is_convertible(want), (name, unit, str(want))
    assert not parsed.is_convertible(want * cf_units.Unit("m")), (name, unit)


def _check_units(path, udunits2: bool = False) -> None:
    """pint: every string parses into the documented dimension; with ``udunits2``,
    UDUNITS2 (cf_units) parses every string into that same dimension."""
    with h5py.File(path, "r") as f:
        for name, (units, per, dims) in _units(path).items():
            assert isinstance(units, str), (name, units)
            parsed = _parse(units)
            spec = DATASETS.get(name)
            if spec is not None:
                assert parsed.dimensionality == _parse(spec.units).dimensionality, name
            if udunits2:
                _check_udunits2(name, units, parsed.dimensionality)
                if spec is not None:
                    assert cf_units.Unit(units).is_convertible(cf_units.Unit(spec.units)), \
                        (name, units, spec.units)
            if name in EXPECTED:
                assert parsed.dimensionality == EXPECTED[name], (name, units)
            if per is not None:
                assert units == "1", name
                n = int(np.prod([_dim_length(f[name], d) for d in str(dims).split()]))
                assert len(per) == n, (name, per, dims)
                parsed_per = [_parse(u).dimensionality for u in per]
                if udunits2:
                    for unit, dim in zip(per, parsed_per):
                        _check_udunits2(name, unit, dim)
                if name in EXPECTED_PER_INDEX:
                    want = EXPECTED_PER_INDEX[name]
                    assert parsed_per[:len(want)] == want, (name, per)


def _dim_length(ds, dim: str) -> int:
    """Length of the axis of ``ds`` whose dimension scale is named ``dim``."""
    for axis in range(ds.ndim):
        for scale in ds.dims[axis].values():
            if scale.name.rsplit("/", 1)[-1] == dim:
                return ds.shape[axis]
    raise AssertionError(f"{ds.name} has no axis {dim}")


#: The files opened in the quick suite (a static, a linearized with compliance, a state
#: space, an arc-length run); the others, 25-40 s each on a busy 2-core machine, are slow.
QUICK = ("bend", "column", "state_space", "arclength")


@pytest.mark.parametrize("key", [k if k in QUICK else pytest.param(k, marks=pytest.mark.slow)
                                 for k in KEYS])
def test_every_group_opens_in_xarray_and_netcdf4(result_files, key):
    _open_everywhere(result_files[key])


@pytest.mark.parametrize("key", KEYS)
def test_every_units_attribute_parses_into_its_dimension(result_files, key):
    _check_units(result_files[key])


@pytest.mark.skipif(cf_units is None, reason=UDUNITS2_MISSING)
@pytest.mark.parametrize("key", KEYS)
def test_every_units_attribute_parses_with_udunits2(result_files, key):
    """The same strings through UDUNITS2 (cf-units' bundled library): the same dimension."""
    _check_units(result_files[key], udunits2=True)


@pytest.mark.skipif(cf_units is None, reason=UDUNITS2_MISSING)
def test_the_udunits2_check_rejects_a_wrong_dimension():
    """The check itself: a unit of another dimension, or one UDUNITS2 cannot parse (a half
    power), fails it."""
    _check_udunits2("x", "N m^2", _parse("N m^2").dimensionality)
    _check_udunits2("x", "1/s", _parse("Hz").dimensionality)
    with pytest.raises(AssertionError):
        _check_udunits2("x", "N m", _parse("N m^2").dimensionality)
    with pytest.raises(AssertionError):
        _check_udunits2("x", "m", _parse("1").dimensionality)
    with pytest.raises(AssertionError, match="cannot parse"):
        _check_udunits2("x", "zorkmid m", _parse("m").dimensionality)
    with pytest.raises(AssertionError, match="no half powers"):
        _check_udunits2("x", "kg^0.5 m", _parse("kg^0.5 m").dimensionality)


def test_the_coordinates_are_the_deck_numbers(result_files):
    """The node axes of /static carry the deck node numbers, the element axis the element
    numbers, the first axis the load factor: xarray selects by them."""
    path = result_files["bend"]
    with xr.open_dataset(path, group="static", engine="h5netcdf") as st, \
            xr.open_dataset(path, group="static/elements/BEAM", engine="netcdf4") as el:
        tip = st.position.sel(position_node=3, coordinate="y").isel(load_factor=-1)
        assert float(st.load_factor[-1]) == 1.0
        assert float(tip) == pytest.approx(53.642106471220565, rel=1e-12)
        assert el.element.values.tolist() == list(range(1, 9))
        assert el.stress_resultant.dims == ("load_factor", "element", "deformation_mode")
        assert st.reaction_component.values.dtype.kind == "U"       # str, not bytes
    with xr.open_dataset(path, group="static/integrity", engine="h5netcdf") as integ:
        assert integ.checksum.dims == ("load_factor", "checked_dataset")


def test_mode_shapes_and_state_space_document_their_units(result_files):
    with h5py.File(result_files["column"], "r") as f:
        assert f["eigen/shape_position"].attrs["units"] == "m"
        assert "phi^T M phi = 1 kg m^2" in f["eigen/shape_position"].attrs["normalization"]
    with h5py.File(result_files["state_space"], "r") as f:
        assert f["state_space/A"].attrs["units"] == "1"
        assert "u_i u_j" in f["state_space/A"].attrs["units_rule"]


def test_sweep_file_opens_with_units(column_sweep):
    _open_everywhere(column_sweep)
    check_units(column_sweep)
    with xr.open_dataset(column_sweep, group="eigen", engine="h5netcdf") as ds:
        assert ds.frequency.attrs["units"] == "Hz"
        assert ds.frequency.dims[-1] == "mode" and ds.frequency.dims[0] in ds.coords


#: One shipped deck's result of each analysis kind (the sweep file is docs/batch.md's sweep),
#: with the groups that make it that kind.
KINDS = {"bend": ("static",), "transient": ("transient",),
         "column": ("eigen", "buckling", "compliance"), "state_space": ("state_space",),
         "arclength": ("critical",), "sweep": ("eigen", "buckling")}


def _kind_file(request, key):
    return request.getfixturevalue("column_sweep") if key == "sweep" else \
        request.getfixturevalue("result_files")[key]


def _netcdf4_walk(path) -> dict:
    """What ``ncdump -h`` shows, by netCDF4-python's calls into the same libnetcdf: {group
    path: {"dims": {name: length}, "vars": {name: dims}}}; every attribute of every group
    and variable is read, and every variable's data."""
    out = {}

    def walk(g, where):
        out[where] = {"dims": {n: len(d) for n, d in g.dimensions.items()}, "vars": {}}
        for att in g.ncattrs():
            g.getncattr(att)
        for name, var in g.variables.items():
            var.set_auto_mask(False)
            for att in var.ncattrs():
                var.getncattr(att)
            data = var[...]
            assert np.shape(data) == var.shape, (where, name)
            out[where]["vars"][name] = tuple(var.dimensions)
            if isinstance(var.datatype, netCDF4.CompoundType):
                COMPOUND.add(f"{where}/{name}".lstrip("/"))
        for name, child in g.groups.items():
            walk(child, f"{where}/{name}".lstrip("/"))
    with netCDF4.Dataset(path) as nc:
        walk(nc, "")
    return out


#: Variables of an unnamed HDF5 compound type (numpy complex): netCDF4-python reads them,
#: but ``ncdump -h`` (4.9) leaves them out of its listing, as it did the unnamed enum of an
#: HDF5 bool before schema 3.1. Writing them with a committed (named) datatype would show
#: them; until then the ncdump test names them and checks that nothing else is hidden.
NCDUMP_HIDES = {"state_space/pole"}
COMPOUND: set = set()
_CDL_VAR = re.compile(r"^\s*(?:string|char|u?byte|u?short|u?int|u?int64|float|double)\s+"
                      r"([^\s(:]+)\s*(?:\(([^)]*)\))?\s*;$")
_CDL_DIM = re.compile(r"^\s*([^\s=]+) = (\d+|UNLIMITED) ;(?: // \((\d+) currently\))?$")


def _parse_cdl_header(text: str) -> dict:
    """``ncdump -h`` output as :func:`_netcdf4_walk`'s dict."""
    out, stack, section = {"": {"dims": {}, "vars": {}}}, [], None
    for line in text.splitlines():
        if m := re.match(r"^\s*group: (\S+) \{$", line):
            stack.append(m[1])
            out["/".join(stack)] = {"dims": {}, "vars": {}}
            section = None
        elif re.match(r"^\s*\} // group ", line):
            stack.pop()
        elif line.strip() in ("dimensions:", "variables:"):
            section = line.strip()[:-1]
        elif section == "dimensions" and (m := _CDL_DIM.match(line)):
            out["/".join(stack)]["dims"][m[1]] = int(m[3] if m[2] == "UNLIMITED" else m[2])
        elif section == "variables" and (m := _CDL_VAR.match(line)):
            dims = tuple(d.strip() for d in m[2].split(",")) if m[2] else ()
            out["/".join(stack)]["vars"][m[1]] = dims
    return out


def check_ncdump(path) -> None:
    """netCDF4-python reads every group, dimension, variable (every HDF5 dataset but the
    hidden dimension scales), attribute and the data of ``path``; where ncdump is installed,
    ``ncdump -h`` exits 0 and lists the same groups, dimensions and variables (but
    :data:`NCDUMP_HIDES`). The batch test runs this on every shipped deck's result."""
    tree = _listed_by_ncdump(path)
    if shutil.which("ncdump") is None:
        return
    done = subprocess.run(["ncdump", "-h", str(path)], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, (path, done.stderr)
    assert _parse_cdl_header(done.stdout) == tree, path


def _listed_by_ncdump(path) -> dict:
    """:func:`_netcdf4_walk` of ``path`` (checked to cover every HDF5 dataset) less the
    variables of :data:`NCDUMP_HIDES` (the only compound-typed ones allowed)."""
    COMPOUND.clear()
    tree = _netcdf4_walk(path)
    walked = {f"{g}/{v}".lstrip("/") for g, node in tree.items() for v in node["vars"]}
    assert walked == _hdf5_variables(path), path
    assert COMPOUND <= NCDUMP_HIDES, (path, COMPOUND)
    for name in COMPOUND:
        group, var = name.rsplit("/", 1)
        del tree[group]["vars"][var]
    return tree


@pytest.mark.parametrize("key", KINDS)
def test_netcdf4_reads_every_group_variable_dimension_and_attribute(request, key):
    """The libnetcdf calls of ``ncdump -h`` (and the data), on one file of each kind."""
    tree = _netcdf4_walk(_kind_file(request, key))
    for group in KINDS[key]:
        assert tree[group]["vars"], (key, group)
    walked = {f"{g}/{v}".lstrip("/") for g, node in tree.items() for v in node["vars"]}
    assert walked == _hdf5_variables(_kind_file(request, key))


def _hdf5_variables(path) -> set:
    """Every HDF5 dataset but the dimension-only scales that netCDF hides."""
    out = set()

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and not str(obj.attrs.get("NAME", b"")).startswith(
                ("This is a netCDF dimension but not", "b'This is a netCDF dimension but not")):
            out.add(name)
    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return out


@pytest.mark.skipif(shutil.which("ncdump") is None, reason="ncdump not installed")
@pytest.mark.parametrize("key", KINDS)
def test_ncdump_shows_every_group_and_variable(request, key):
    """``ncdump -h`` on the whole file exits 0 and shows every group, dimension (with its
    length) and variable (with its dimensions) that netCDF4-python finds; ``-g`` on each
    top-level group shows that group (ncdump 4.9 prints /model with it)."""
    path = _kind_file(request, key)
    check_ncdump(path)
    tree = _listed_by_ncdump(path)
    for group in KINDS[key]:
        done = subprocess.run(["ncdump", "-h", "-g", group, str(path)], capture_output=True,
                              text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        assert _parse_cdl_header(done.stdout)[group] == tree[group]


@pytest.mark.skipif(shutil.which("udunits2") is None,
                    reason="UDUNITS2 (udunits-bin's udunits2) not installed")
@pytest.mark.parametrize("key", ("frame", "column", "transient", "state_space"))
def test_udunits2_parses_every_unit(result_files, key):
    units = set()
    for unit, per, _ in _units(result_files[key]).values():
        units.add(unit)
        units.update(per or ())
    for unit in sorted(units):
        # the program reads a leading number as the amount ("1/N" would be 1 of "/N"): the
        # amount is given, so the whole string is read as the unit, as the library does
        done = subprocess.run(["udunits2", "-H", f"1 {unit}", "-W", ""], capture_output=True,
                              text=True, timeout=30)
        assert done.returncode == 0 and "recognize" not in done.stdout + done.stderr, \
            (unit, done.stdout, done.stderr)


def test_older_files_still_read_and_validate(result_files, tmp_path):
    """Schema 2.x files (checksums in /<group>/checksum, the 2.x unit strings, no dimension
    scales) are read and validated, and a changed value in one is still reported as damage:
    every shipped 2.x baseline, and a 3.0 file turned into the 2.22 layout."""
    from pathlib import Path

    from spacarpy.results import open_results, validate_file
    from spacarpy.results.h5file import ResultsFormatError

    from helpers import as_schema_2

    base = Path(__file__).resolve().parents[1] / "decks" / "baseline"
    for path in sorted(base.glob("*.h5")):
        with h5py.File(path, "r") as f:
            if int(f.attrs["schema_version"][0]) != 2:
                continue
        assert validate_file(path) == [], path
    v30 = tmp_path / "v30.h5"                  # 3.0 stored coordinate_fixed as an HDF5 bool
    shutil.copy(result_files["column"], v30)
    with h5py.File(v30, "r+") as f:
        _as_bool_coordinate_fixed(f, (3, 0))
    assert validate_file(v30) == []
    with open_results(v30) as res, open_results(result_files["column"]) as new:
        assert res.model.coordinate_fixed.dtype == new.model.coordinate_fixed.dtype == bool
        np.testing.assert_array_equal(res.model.coordinate_fixed, new.model.coordinate_fixed)
        assert res.model.coordinate_fixed.sum() > 0
    with h5py.File(v30, "r+") as f:             # a 3.1 file must not hold the bool
        _as_bool_coordinate_fixed(f, (3, 1))
    assert any("/model/coordinate_fixed has dtype bool" in p for p in validate_file(v30))
    old = tmp_path / "old.h5"
    shutil.copy(result_files["column"], old)
    with h5py.File(old, "r+") as f:
        as_schema_2(f, 22)
        assert "eigen/checksum" in f and "eigen/integrity" not in f
    assert validate_file(old) == []
    with open_results(result_files["column"]) as new, open_results(old) as res:
        np.testing.assert_array_equal(res.eigen.frequency, new.eigen.frequency)
        assert res.static.reaction_component == new.static.reaction_component
    with h5py.File(old, "r+") as f:
        f["eigen/frequency"][1, 0] += 1e-9
    assert any("/eigen/frequency is damaged at step 1" in p for p in validate_file(old))
    with pytest.raises(ResultsFormatError, match="frequency"), open_results(old) as res:
        assert res.eigen.frequency is None


def _as_bool_coordinate_fixed(f, version) -> None:
    """/model/coordinate_fixed as 3.0 wrote it (an HDF5 bool, same CRC-32: one byte 0/1)."""
    from spacarpy.results.header_crc import HEADER_CRC_ATTR, header_crc

    ds = f["model/coordinate_fixed"]
    values, attrs = ds[...].astype(bool), dict(ds.attrs)
    attrs.pop("DIMENSION_LIST", None)
    del f["model/coordinate_fixed"]
    new = f["model"].create_dataset("coordinate_fixed", data=values)
    for key, value in attrs.items():
        new.attrs[key] = value
    new.dims[0].attach_scale(f["model/global_coordinate"])
    f.attrs["schema_version"] = np.array(version, dtype=np.int32)
    f.attrs[HEADER_CRC_ATTR] = header_crc(f.attrs)
