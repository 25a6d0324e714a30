"""No code outside odolab.core.models asks which kind a model is (issue 41).

A model kind is named where a file imports a kind's class or module (``SlipModel``,
``odolab.core.models.slip``, ...), tests ``isinstance`` against a model class or protocol, or compares
a model's ``kind`` (``params.model.kind == "slip"``). Everything else asks a capability
(:func:`odolab.core.models.timed_model`, :func:`odolab.core.models.own_covariance`) or the model itself, so
that a new model is one module in ``models/`` plus its registration (docs/architecture.md).

:data:`ALLOWED` lists the files outside ``models/`` that may name a kind, each with why; the test
fails when another file starts to, and when a listed file no longer does (drop it from the list).
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

from odolab.core.models import MODELS

SRC = Path(__file__).resolve().parents[2] / "src" / "odolab"

#: file (relative to src/odolab) -> why it may name a model kind
ALLOWED: dict[str, str] = {
    # issue 37 (slip fitting) owns these: a fit builds the kind it fits; lsq.py should read a
    # model's keys through model.to_dict() / the registry (MODELS[kind]) instead of isinstance
    "calibration/lsq.py": "fits each kind's own parameters (issue 37's)",
    "calibration/slipfit.py": "fits the slip model (issue 37's)",
    "calibration/slipfilter.py": "the slip fit's Kalman filter, with a noisy truth (issue 37's)",
    "sim/presets.py": "a preset's true robot is a particular model (data, not a branch)",
    "core/slip_uncertainty.py": "the old place of odolab.core.models.slip_covariance: a re-export",
}

#: the classes and modules that are a kind's own
KIND_CLASSES = {cls.__name__ for cls in MODELS.values()}
KIND_MODULES = {cls.__module__ for cls in MODELS.values()} | {
    "odolab.core.models.slip_covariance",
    "odolab.core.models.slip_terms",
}
#: what ``isinstance`` may not test outside models/: a kind, or the protocols (asked through
#: odolab.core.models.is_kinematic_model, timed_model and own_covariance)
MODEL_TYPES = KIND_CLASSES | {"KinematicModel", "TimedModel", "CovarianceModel"}


def _name(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return ""


def kind_namings(tree: ast.AST) -> Iterator[tuple[int, str]]:
    """(line, what) for each place the syntax tree names a model kind (module docstring)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            names = {a.name for a in node.names}
            if node.module in KIND_MODULES:
                yield node.lineno, f"imports {node.module}"
            elif node.module.startswith("odolab.core.models") and names & KIND_CLASSES:
                yield node.lineno, f"imports {', '.join(sorted(names & KIND_CLASSES))}"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in KIND_MODULES:
                    yield node.lineno, f"imports {alias.name}"
        elif (
            isinstance(node, ast.Call) and _name(node.func) == "isinstance" and len(node.args) == 2
        ):
            arg = node.args[1]
            types = arg.elts if isinstance(arg, ast.Tuple) else [arg]
            hit = sorted({_name(t) for t in types} & MODEL_TYPES)
            if hit:
                yield node.lineno, f"isinstance(..., {', '.join(hit)})"
        elif isinstance(node, ast.Compare):
            for side in (node.left, *node.comparators):
                if (
                    isinstance(side, ast.Attribute)
                    and side.attr == "kind"
                    and "model" in ast.unparse(side.value).lower()
                ):
                    yield node.lineno, f"compares {ast.unparse(side)}"
                    break


def namings() -> dict[str, list[str]]:
    """Every file outside models/ that names a model kind, with its places."""
    out: dict[str, list[str]] = {}
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel.startswith("core/models/"):
            continue
        text = path.read_text()
        if not any(word in text for word in ("odolab.core.models", "Model", "DiffDrive", ".kind")):
            continue  # names nothing the detector looks for: no need to parse it
        found = [f"{line}: {what}" for line, what in kind_namings(ast.parse(text))]
        if found:
            out[rel] = found
    return out


def test_only_models_and_the_listed_files_name_a_model_kind() -> None:
    found = namings()
    new = {f: places for f, places in found.items() if f not in ALLOWED}
    assert not new, (
        f"model kinds named outside odolab.core.models: {new}; ask a capability "
        "(odolab.core.models.timed_model, own_covariance, model_words) or add it to the model"
    )
    stale = sorted(set(ALLOWED) - set(found))
    assert not stale, f"no longer name a model kind, drop them from ALLOWED: {stale}"


def test_the_detector_finds_each_form_of_kind_naming() -> None:
    source = (
        "from odolab.core.models import SlipModel, DIFF_DRIVE\n"
        "import odolab.core.models.icr\n"
        "from odolab.core.models.slip import FEATURES\n"
        "isinstance(m, (int, IcrModel))\n"
        "isinstance(m, KinematicModel)\n"
        "if params.model.kind == 'slip': pass\n"
        # not kind namings: a capability, a kind-free import, a camera model
        "from odolab.core.models import own_covariance, DIFF_DRIVE\n"
        "isinstance(c, CameraModel)\n"
        "if source == 'noise': pass\n"
    )
    lines = [line for line, _ in kind_namings(ast.parse(source))]
    assert sorted(lines) == [1, 2, 3, 4, 5, 6]


def test_every_registered_kind_lives_in_models() -> None:
    for kind, cls in MODELS.items():
        assert cls.__module__.startswith("odolab.core.models."), (kind, cls.__module__)
        assert cls.kind == kind
