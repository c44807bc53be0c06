"""TOML tube configuration: examples, round trip, schema features and every rejected input."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest

import biplan
from biplan import ConfigError, Development, LinearLaw, ModelOptions, TrilinearLaw, Tube
from biplan.io.config import dump_config, load_config, load_config_text, tube_from_dict
from biplan.io.config_reader import ConfigFileError
from biplan.options import MirrorConvention, TransitionReading

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

BASE = """\
name = "test tube"

[geometry]
radius = 2.0
pitch = 3.6
helical_angle = 60.0
n_modules = 6

[laws.helical]
type = "linear"
stiffness = 1.3

[laws.circular]
type = "trilinear"
stiffness = [0.9, -0.2, 0.6]
transitions = [0.2, 1.3]
bistable = true

[options]
mirror = "reflection"
"""

CIRCULAR = TrilinearLaw((0.9, -0.2, 0.6), (0.2, 1.3))


def _override(fold: str, index: object, extra: str = "") -> str:
    return (
        f'\n[[laws.override]]\nfold = "{fold}"\nindex = {index}\n'
        f'type = "linear"\nstiffness = 2.0\n{extra}'
    )


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "tube.toml"
    path.write_text(text, encoding="utf-8")
    return path


# --- examples and round trip ----------------------------------------------------------------
@pytest.mark.parametrize(
    ("filename", "design"),
    [
        ("semi_bistable.toml", biplan.designs.semi_bistable),
        ("fully_bistable_4.toml", biplan.designs.fully_bistable),
        ("fully_bistable_8.toml", lambda: biplan.designs.fully_bistable(n_modules=8)),
    ],
)
def test_example_equals_design(filename: str, design: object) -> None:
    assert load_config(EXAMPLES / filename) == design()  # type: ignore[operator]


def _mixed_tube() -> Tube:
    options = ModelOptions(transition_reading="branch_lengths", mirror="point", contact="minimum")
    tube = Tube.uniform(
        radius=2.5,
        pitch=3.1,
        helical_angle=47.25,
        n_modules=5,
        helical=LinearLaw(1.1),
        circular=TrilinearLaw((0.9, -0.3, 0.6), (0.1, 1.7)),
        base_fold=False,
        options=options,
        surface_density=1.25e-9,
        name='odd "name" \\ with\nnewline, tab\t, ünïcode and \x7f',
    )
    tube = tube.with_law(("circular", 2), TrilinearLaw((0.8, -0.25, 0.5), (0.3, 1.1)))
    return tube.with_law(("helical", 4), TrilinearLaw((2.0, -1.6, 1.0), (0.05, 0.3)))


@pytest.mark.parametrize(
    "tube",
    [
        biplan.designs.semi_bistable(),
        biplan.designs.fully_bistable(),
        biplan.designs.semi_bistable(ModelOptions(transition_reading="branch_lengths")),
        _mixed_tube(),
        Tube.uniform(
            radius=1.0,
            pitch=1.0,
            helical_angle=30.0,
            n_modules=1,
            helical=LinearLaw(3.0),
            circular=LinearLaw(1.0),
            base_fold=False,
        ),
    ],
    ids=["semi", "fully", "semi-branch-lengths", "mixed", "single-module"],
)
def test_round_trip(tmp_path: Path, tube: Tube) -> None:
    path = _write(tmp_path, dump_config(tube))
    assert load_config(path) == tube
    assert load_config_text(dump_config(tube)) == tube


def test_round_trip_branch_lengths_within_one_ulp() -> None:
    # w1 + (w2 − w1) can fall on a rounding tie: no table entry gives w2 exactly
    tube = biplan.designs.semi_bistable(ModelOptions(transition_reading="branch_lengths"))
    tube = tube.with_law(("circular", 1), TrilinearLaw((0.9, -0.3, 0.6), (0.13, 1.7)))
    w1, w2 = load_config_text(dump_config(tube)).circular_laws[1].transitions
    assert w1 == 0.13
    assert abs(w2 - 1.7) <= math.ulp(1.7)


def test_dump_writes_overrides_only_for_differing_folds() -> None:
    text = dump_config(_mixed_tube())
    assert text.count("[[laws.override]]") == 2
    assert "[laws.helical]" in text and "[laws.circular]" in text


# --- schema features ------------------------------------------------------------------------
def test_b_gives_expected_helical_angle() -> None:
    tube = load_config_text(BASE.replace("helical_angle = 60.0", "b = 0.573"))
    expected = Development.helical_angle_for_b(0.573, 2.0, 3.6)
    assert tube.development.helical_angle == expected
    assert math.isclose(tube.b, 0.573, rel_tol=1e-12)


def test_overrides_land_on_the_right_fold() -> None:
    text = BASE + _override("circular", 0) + _override("helical", 5)
    tube = load_config_text(text)
    assert tube.circular_laws[0] == LinearLaw(2.0)
    assert tube.circular_laws[1:] == (CIRCULAR,) * 5
    assert tube.helical_laws[5] == LinearLaw(2.0)
    assert tube.helical_laws[:5] == (LinearLaw(1.3),) * 5


def test_override_with_trilinear_law() -> None:
    text = BASE + (
        '\n[[laws.override]]\nfold = "helical"\nindex = 2\ntype = "trilinear"\n'
        "stiffness = [2.0, -1.6, 1.0]\ntransitions = [0.05, 0.3]\nbistable = true\n"
    )
    tube = load_config_text(text)
    assert tube.helical_laws[2] == TrilinearLaw((2.0, -1.6, 1.0), (0.05, 0.3))


def test_options_are_parsed() -> None:
    text = BASE.replace(
        'mirror = "reflection"',
        'mirror = "point"\ntransition_reading = "branch_lengths"\n'
        "weak_contacts_active = true\ncontact_smoothing = 1e-5\ncontact_compliance = 0.0",
    )
    tube = load_config_text(text)
    assert tube.options.mirror is MirrorConvention.POINT
    assert tube.options.transition_reading is TransitionReading.BRANCH_LENGTHS
    assert tube.options.weak_contacts_active is True
    assert tube.options.contact_smoothing == 1e-5
    assert tube.options.contact_compliance == 0.0
    # transitions are read with the configured reading: w2 = l1 + l2
    assert tube.circular_laws[0].transitions == (0.2, 1.5)


def test_optional_keys_and_defaults() -> None:
    text = BASE.replace('name = "test tube"\n', "").replace(
        '[options]\nmirror = "reflection"\n', ""
    )
    tube = load_config_text(text)
    assert tube.name == ""
    assert tube.base_fold is True
    assert tube.options == ModelOptions()
    assert tube.surface_density == Tube.__dataclass_fields__["surface_density"].default


def test_circular_table_optional_without_circular_folds() -> None:
    text = BASE.replace("n_modules = 6", "n_modules = 1\nbase_fold = false")
    text = text.split("[laws.circular]")[0]
    tube = load_config_text(text)
    assert tube.circular_laws == ()


def test_tube_from_dict() -> None:
    data = {
        "geometry": {"radius": 2, "pitch": 3.6, "helical_angle": 60, "n_modules": 2},
        "laws": {
            "helical": {"type": "linear", "stiffness": 1.3},
            "circular": {"type": "linear", "stiffness": 0.9},
        },
    }
    tube = tube_from_dict(data)
    assert tube.n_circular == 2 and tube.development.radius == 2.0
    data["geometry"]["radius"] = -2  # type: ignore[index]
    with pytest.raises(ConfigError, match=r"^<dict>: .*geometry\.radius"):
        tube_from_dict(data)


# --- rejected inputs ------------------------------------------------------------------------
_BAD = [
    # geometry ranges and types
    ("radius = 2.0", "radius = 0.0", "geometry.radius"),
    ("radius = 2.0", "radius = -1.0", "geometry.radius"),
    ("radius = 2.0", 'radius = "2.0"', "geometry.radius"),
    ("pitch = 3.6", "pitch = 0", "geometry.pitch"),
    ("pitch = 3.6", "pitch = -3.6", "geometry.pitch"),
    ("n_modules = 6", "n_modules = 0", "geometry.n_modules"),
    ("n_modules = 6", "n_modules = -2", "geometry.n_modules"),
    ("n_modules = 6", "n_modules = 2.5", "geometry.n_modules"),
    ("n_modules = 6", "n_modules = 6.0", "geometry.n_modules"),
    ("n_modules = 6", "n_modules = true", "geometry.n_modules"),
    ("helical_angle = 60.0", "helical_angle = 0.0", "geometry.helical_angle"),
    ("helical_angle = 60.0", "helical_angle = 90.0", "geometry.helical_angle"),
    ("helical_angle = 60.0", "helical_angle = -10.0", "geometry.helical_angle"),
    ("radius = 2.0", "radius = 0.5", "geometry.helical_angle"),  # H2 = l tan β ≥ H
    ("helical_angle = 60.0", "b = 0.1", "geometry.b"),  # b < l/H
    ("helical_angle = 60.0", "b = 5.0", "geometry.b"),  # β from b too steep
    ("helical_angle = 60.0", "b = inf", "geometry.b"),
    ("helical_angle = 60.0", "b = 0.573\nhelical_angle = 60.0", "geometry.b"),
    ("n_modules = 6", "n_modules = 6\nbase_fold = 1", "geometry.base_fold"),
    ("n_modules = 6", "n_modules = 6\nsurface_density = 0.0", "geometry.surface_density"),
    ('name = "test tube"', "name = 3", "name"),
    # non-finite numbers
    ("radius = 2.0", "radius = nan", "geometry.radius"),
    ("pitch = 3.6", "pitch = inf", "geometry.pitch"),
    ("helical_angle = 60.0", "helical_angle = -inf", "geometry.helical_angle"),
    ("stiffness = 1.3", "stiffness = inf", "laws.helical.stiffness"),
    ("[0.9, -0.2, 0.6]", "[0.9, nan, 0.6]", "laws.circular.stiffness[1]"),
    ("[0.2, 1.3]", "[0.2, inf]", "laws.circular.transitions[1]"),
    # laws
    ("[0.2, 1.3]", "[1.3, 0.2]", "laws.circular.transitions[1]"),  # l1 ≥ l2
    ("[0.2, 1.3]", "[0.2, 0.2]", "laws.circular.transitions[1]"),
    ("[0.2, 1.3]", "[0.0, 1.3]", "laws.circular.transitions[0]"),
    ("[0.2, 1.3]", "[0.2]", "laws.circular.transitions"),
    ("[0.9, -0.2, 0.6]", "[0.9, -0.2]", "laws.circular.stiffness"),
    ("[0.9, -0.2, 0.6]", "[-0.9, -0.2, 0.6]", "laws.circular.stiffness[0]"),
    ("[0.9, -0.2, 0.6]", "[0.9, -0.01, 0.6]", "laws.circular"),  # not bistable
    ("stiffness = 1.3", "stiffness = 1.3\nbistable = true", "laws.helical"),  # linear
    ("stiffness = 1.3", "stiffness = -1.3", "laws.helical.stiffness"),
    ("stiffness = 1.3", 'stiffness = "1.3"', "laws.helical.stiffness"),
    ("stiffness = 1.3", "stiffness = [1.3]", "laws.helical.stiffness"),
    ("stiffness = 1.3", "stiffness = 1.3\ntransitions = [0.1, 0.2]", "laws.helical.transitions"),
    ('type = "linear"', 'type = "quadratic"', "laws.helical.type"),
    ("bistable = true", 'bistable = "yes"', "laws.circular.bistable"),
    # unknown keys
    ('name = "test tube"', 'name = "test tube"\ncolour = "red"', "colour"),
    ("n_modules = 6", "n_modules = 6\nheight = 21.6", "geometry.height"),
    ("stiffness = 1.3", "stiffness = 1.3\nC = 1.444", "laws.helical.C"),
    ("[laws.helical]", "[laws.diagonal]\ntype = 1\n[laws.helical]", "laws.diagonal"),
    ('mirror = "reflection"', 'mirror = "reflection"\nsmoothing = 1', "options.smoothing"),
    # options values
    ('mirror = "reflection"', 'mirror = "glide"', "options.mirror"),
    ('mirror = "reflection"', "mirror = 1", "options.mirror"),
    ('mirror = "reflection"', 'transition_reading = "relative"', "options.transition_reading"),
    ('mirror = "reflection"', "weak_contacts_active = 1", "options.weak_contacts_active"),
    ('mirror = "reflection"', "contact_smoothing = -1.0", "options.contact_smoothing"),
    ('mirror = "reflection"', "contact_smoothing = nan", "options.contact_smoothing"),
    ('mirror = "reflection"', "contact_compliance = -1e-6", "options.contact_compliance"),
    ('mirror = "reflection"', "contact_compliance = 0.01", "options.contact_compliance"),
    # missing required keys and tables
    ("radius = 2.0\n", "", "geometry.radius"),
    ("helical_angle = 60.0\n", "", "geometry.helical_angle"),
    ("n_modules = 6\n", "", "geometry.n_modules"),
    ('type = "linear"\n', "", "laws.helical.type"),
    ("stiffness = 1.3\n", "", "laws.helical.stiffness"),
    ("transitions = [0.2, 1.3]\n", "", "laws.circular.transitions"),
    ("[geometry]", "[geometri]", "geometri"),
    ("[laws.circular]", "[laws.circular_]", "laws.circular_"),
]


@pytest.mark.parametrize(("old", "new", "parameter"), _BAD, ids=[c[2] for c in _BAD])
def test_bad_input_raises_config_error(tmp_path: Path, old: str, new: str, parameter: str) -> None:
    assert old in BASE
    path = _write(tmp_path, BASE.replace(old, new, 1))
    with pytest.raises(ConfigError) as info:
        load_config(path)
    err = info.value
    assert isinstance(err, ConfigFileError) and isinstance(err, ValueError)
    assert err.parameter == parameter
    assert parameter in str(err)
    assert str(err).startswith(f"{path}: ")


_BAD_OVERRIDES = [
    (_override("helical", 6), "laws.override[0].index"),
    (_override("circular", 0) + _override("circular", 6), "laws.override[1].index"),
    (_override("helical", -1), "laws.override[0].index"),
    (_override("helical", '"0"'), "laws.override[0].index"),
    (_override("helical", 1) + _override("helical", 1), "laws.override[1].index"),
    (_override("diagonal", 0), "laws.override[0].fold"),
    (_override("helical", 0, "colour = 1\n"), "laws.override[0].colour"),
    (_override("helical", 0, "bistable = true\n"), "laws.override[0]"),
    ('\n[laws.override]\nfold = "helical"\n', "laws.override"),
    ('\n[[laws.override]]\nfold = "helical"\n', "laws.override[0].index"),
]


@pytest.mark.parametrize(("extra", "parameter"), _BAD_OVERRIDES, ids=[c[1] for c in _BAD_OVERRIDES])
def test_bad_override_raises_config_error(extra: str, parameter: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_config_text(BASE + extra, "cfg.toml")
    assert info.value.parameter == parameter
    assert str(info.value).startswith("cfg.toml: ")


_LAWS = {
    "helical": {"type": "linear", "stiffness": 1.3},
    "circular": {"type": "linear", "stiffness": 1},
}
_GEOMETRY = {"radius": 2.0, "pitch": 3.6, "helical_angle": 60.0, "n_modules": 2}


@pytest.mark.parametrize(
    ("data", "parameter"),
    [
        ([1, 2], "<document>"),
        ({"geometry": 1, "laws": _LAWS}, "geometry"),
        ({"geometry": _GEOMETRY, "laws": []}, "laws"),
        ({"geometry": _GEOMETRY, "laws": {**_LAWS, "helical": 1.3}}, "laws.helical"),
        ({"geometry": _GEOMETRY, "laws": _LAWS, "options": "point"}, "options"),
        ({"geometry": _GEOMETRY}, "laws"),
        ({"laws": _LAWS}, "geometry"),
        ({"geometry": _GEOMETRY, "laws": {"helical": _LAWS["helical"]}}, "laws.circular"),
    ],
)
def test_bad_table_raises_config_error(data: object, parameter: str) -> None:
    with pytest.raises(ConfigError) as info:
        tube_from_dict(data, "x.toml")  # type: ignore[arg-type]
    assert info.value.parameter == parameter
    assert str(info.value).startswith("x.toml: ")


def test_unknown_key_lists_valid_keys() -> None:
    with pytest.raises(ConfigError, match=r"geometry\.height.*radius, pitch, helical_angle, b"):
        load_config_text(BASE.replace("n_modules = 6", "n_modules = 6\nheight = 1.0"))


def test_toml_syntax_error(tmp_path: Path) -> None:
    path = _write(tmp_path, BASE.replace("radius = 2.0", "radius = 2.0 mm"))
    with pytest.raises(ConfigError, match=r"line 4") as info:
        load_config(path)
    assert info.value.parameter == "toml"
    assert str(info.value).startswith(f"{path}: ")


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "missing.toml"
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert info.value.parameter == "path"
    assert str(path) in str(info.value)


@pytest.mark.parametrize("path", [42, None, 3.5, ["a.toml"]])
def test_load_config_of_a_non_path_is_a_config_error(path: object) -> None:
    with pytest.raises(ConfigError, match="path") as info:
        load_config(path)  # type: ignore[arg-type]
    assert info.value.parameter == "path" and info.value.value == path


def test_numpy_integers_are_integers() -> None:
    """Counts given as NumPy integers (from an array, a grid) build the same objects as ints."""
    import numpy as np

    kwargs = {"radius": 2.0, "pitch": 3.6, "helical_angle": 60.0,
              "helical": LinearLaw(1.3), "circular": LinearLaw(0.9)}  # fmt: skip
    tube = Tube.uniform(n_modules=np.int64(4), **kwargs)
    assert tube == Tube.uniform(n_modules=4, **kwargs) and type(tube.n_modules) is int
    assert load_config_text(dump_config(tube)) == tube
    fully = biplan.designs.fully_bistable(n_modules=np.int64(4))
    assert fully == biplan.designs.fully_bistable() and type(fully.n_modules) is int
    assert biplan.Newton(max_steps=np.int32(7)).max_steps == 7
    assert biplan.ArcLength(max_steps=np.uint16(9)).max_steps == 9
    data = tomllib.loads(BASE)
    data["geometry"]["n_modules"] = np.int64(6)
    assert tube_from_dict(data).n_modules == 6
    for bad in (4.0, True, "4", np.float64(4.0)):
        with pytest.raises(ConfigError, match="n_modules"):
            Tube.uniform(n_modules=bad, **kwargs)


@pytest.mark.parametrize("radius", [0.0, -2.0, float("nan")])
def test_pressure_load_needs_a_positive_radius(radius: float) -> None:
    with pytest.raises(ConfigError, match="radius") as info:
        biplan.Load.of_pressure(0.1, radius=radius)
    assert info.value.parameter == "radius"
