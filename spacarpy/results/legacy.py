"""Where a dataset lives in an older results file: the map from the 1.x names (schema 1.x
stored BEAM data at ``/static/deformation`` and the other kinds at
``/static/truss_deformation`` ...) and the 2.x place of the checksums.

This module's one job is that map (:data:`LEGACY_NAMES`, :func:`legacy_name`,
:func:`new_name`); :mod:`spacarpy.results.schema` re-exports it with the table of datasets.
"""
from __future__ import annotations

from spacarpy.elements.registry import KINDS as _KINDS

__all__ = ["LEGACY_NAMES", "LEGACY_OPTIONAL", "LEGACY_DROPPED", "legacy_name", "new_name"]

KIND_NAMES = tuple(_KINDS)

# 1.x names of the BEAM datasets that moved (2.0 name -> 1.x name)
_BEAM_LEGACY = {
    "model/elements/BEAM/ids": "model/elements",
    "model/elements/BEAM/nodes": "model/element_nodes",
    "model/elements/BEAM/position_rows": "model/element_position_rows",
    "model/elements/BEAM/length": "model/element_length",
    "model/elements/BEAM/axes": "model/element_axes",
    "model/elements/BEAM/deformation_class": "model/element_deformation_class",
    "model/elements/BEAM/stiffness": "model/element_stiffness",
    "model/elements/BEAM/mass": "model/element_mass",
    "model/elements/BEAM/cross_section_type": "model/cross_section_type",
    "model/elements/BEAM/cross_section_dims": "model/cross_section_dims",
    "static/elements/BEAM/deformation": "static/deformation",
    "static/elements/BEAM/stress_resultant": "static/stress_resultant",
    "static/elements/BEAM/max_normal_stress": "static/max_normal_stress",
    "static/elements/BEAM/max_von_mises_stress": "static/max_von_mises_stress",
    "transient/elements/BEAM/deformation": "transient/deformation",
    "transient/elements/BEAM/stress_resultant": "transient/stress_resultant",
}

#: 2.0 path -> 1.x path of every dataset that moved in schema 2.0. Paths not listed kept
#: their name. ``/model/element_type`` (1.x: "BEAM" for every BEAM element) has no 2.0
#: twin: the kind is the group name.
LEGACY_NAMES: dict[str, str] = {
    **_BEAM_LEGACY,
    **{f"model/elements/{k}/{new}": f"model/{k.lower()}_{old}"
       for k in KIND_NAMES if k != "BEAM"
       for new, old in (("ids", "elements"), ("nodes", "element_nodes"))},
    **{f"{g}/elements/{k}/{w}": f"{g}/{k.lower()}_{w}"
       for k in KIND_NAMES if k != "BEAM" for g in ("static", "transient")
       for w in ("deformation", "stress_resultant")},
}
_NEW_NAMES = {old: new for new, old in LEGACY_NAMES.items()}
#: Datasets that 1.x files may lack although their schema version has them:
#: ``/transient/dissipated_energy`` was added within schema 1.4.
LEGACY_OPTIONAL = ("transient/dissipated_energy",)
#: 1.x datasets dropped in 2.0.
LEGACY_DROPPED = ("model/element_type",)


def legacy_name(path: str, major: int) -> str:
    """Where the dataset ``path`` (its current name) lives in a file of schema major version
    ``major``: 1.x names (:data:`LEGACY_NAMES`), and a 2.x file's ``/<group>/checksum``
    (3.0: ``/<group>/integrity/checksum``)."""
    if major < 3 and path.endswith("/integrity/checksum"):
        return path[:-len("/integrity/checksum")] + "/checksum"
    return LEGACY_NAMES.get(path, path) if major < 2 else path


def new_name(path: str) -> str | None:
    """2.0 name of the 1.x dataset ``path`` (leading ``/`` kept); None if dropped."""
    lead = "/" if path.startswith("/") else ""
    p = path.lstrip("/")
    if p in LEGACY_DROPPED:
        return None
    return lead + _NEW_NAMES.get(p, p)


