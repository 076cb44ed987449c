"""README "Your own recording": every command between the markers runs, in order, and says what it should.

The commands are taken from README.md as written (```sh blocks between
``<!-- own-recording:start`` and ``<!-- own-recording:end -->``), run through the installed
``sizefx`` console script in a fresh folder that links ``examples`` to the repository's, and
their outputs are checked against the truth the example was simulated with
(``examples/tumble_truth.json``). A README that drops a step, names a wrong column or stops
writing an output fails here. The example files themselves must regenerate bit for bit.

After each ```sh block the README shows what its commands print (a ```text block): every line
shown there must be in the printed output (stdout and stderr, whitespace normalised), a line of
``...`` stands for lines left out and ``...`` inside a line for text left out (a wall time, the
rest of a long line). The tutorial cannot drift from the code.
"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
EXAMPLES = ROOT / "examples"
START, END = "<!-- own-recording:start", "<!-- own-recording:end -->"
SIZEFX = Path(sys.executable).with_name("sizefx")
EXAMPLE_FILES = ("tumble_imu.csv", "tumble_reference.csv", "tumble_truth.json")
#: Under about 1.5 MB: the example travels with every clone.
EXAMPLE_MAX_BYTES = 1_500_000
#: What the walk-through must contain, in this order: (command, must have, must not have).
STEPS = (
    ("import csv", "--reference-quaternion", None),
    ("inspect", None, None),
    ("diagnose", "--json", None),
    ("calibrate", "--json", None),
    ("navigate", None, "--levers"),
    ("navigate", "--levers", None),
    ("compare", "--json", None),
)

# Tolerances, each with its reason.
#: Calibrated arms against the truth, in their own sigma: every one of the nine components within
#: 4 sigma (the 50 Hz reference is interpolated by a rotation spline; slerp had biased the arms by
#: many sigma). 4 sigma: a 1-in-16000 false alarm per component; a missed arm (3.0 mm) is hundreds
#: of sigma off. The measured arms and sigmas: benchmarks/results/accuracy_own_recording.json.
ARM_Z = 4.0
#: Calibrated accelerometer delay against the truth [s]: within 3 us of the 1 ms truth. That leaves
#: room for a small bias of the fit (its sigma is a fraction of a microsecond) and still fails for a
#: wrong sign or units (1000 us off). The measured delay: benchmarks/results/accuracy_own_recording.json.
DELAY_TOL_S = 3e-6
#: diagnose's estimates against the truth, in their own sigma (no interpolation bias: diagnose fits
#: the reference with splines). 4 sigma: a 1-in-16000 false alarm per parameter.
DIAGNOSE_Z = 4.0
#: Navigation: the arms must remove most of the error. After the two minutes the compensated solution
#: must be under 1.5 m from the reference and the plain one over 15 m and ten times as far. Most of
#: what remains with the arms is the navigation's own error at 50 Hz on this tumble (an ideal record
#: navigated the same way shows it); the measured errors are in
#: benchmarks/results/accuracy_own_recording.json. The bounds leave room for a better or worse
#: algorithm, not for arms that fail to compensate.
COMPENSATED_MAX_M = 1.5
PLAIN_MIN_M = 15.0
GAIN_MIN = 10.0
#: In a shown output: a line of its own stands for lines left out, inside a line for text left out.
ELISION = "..."


def normalised(line: str) -> str:
    """``line`` with its runs of whitespace as single spaces, stripped."""
    return " ".join(line.split())


def readme_walk(text: str) -> list:
    """The ```sh blocks between the markers, in order, each as ``(commands, shown)``: ``commands`` a
    list of argv lists, ``shown`` the lines of the ```text blocks that follow it (up to the next
    ```sh block), whitespace normalised, without blank lines and :data:`ELISION` lines."""
    if START not in text or END not in text:
        raise AssertionError(f"README markers {START!r} ... {END!r} are missing")
    section = text.split(START, 1)[1].split(END, 1)[0]
    walk = []
    for kind, block in re.findall(r"^```(sh|text)\n(.*?)^```", section, flags=re.S | re.M):
        if kind == "text":
            if not walk:
                raise AssertionError(f"README shows an output before any command: {block[:60]!r}")
            walk[-1][1].extend(n for n in map(normalised, block.splitlines()) if n and n != ELISION)
            continue
        commands = []
        for line in block.replace("\\\n", " ").splitlines():
            argv = shlex.split(line, comments=True)
            if argv:
                commands.append(argv)
        walk.append((commands, []))
    return walk


def readme_commands(text: str) -> list:
    """The commands of the ```sh blocks between the markers: a list of argv lists."""
    return [argv for commands, _ in readme_walk(text) for argv in commands]


def not_printed(shown: list, printed: str) -> list:
    """The lines of ``shown`` (normalised) that no line of ``printed`` holds; :data:`ELISION` inside a
    shown line matches any text within the printed line."""
    lines = [normalised(line) for line in printed.splitlines()]
    missing = []
    for line in shown:
        found = re.compile(".*?".join(re.escape(piece.strip()) for piece in line.split(ELISION)))
        if not any(found.search(p) for p in lines):
            missing.append(line)
    return missing


def check_steps(commands: list):
    """Every step of :data:`STEPS` in order, each a ``sizefx`` command; raise AssertionError naming a missing one."""
    for argv in commands:
        assert argv[0] == "sizefx", f"not a sizefx command: {shlex.join(argv)}"
    k = 0
    for argv in commands:
        verb, has, lacks = STEPS[k] if k < len(STEPS) else (None, None, None)
        line = " ".join(argv[1:])
        if verb and line.startswith(verb) and (has is None or has in argv) and (lacks is None or lacks not in argv):
            k += 1
    if k < len(STEPS):
        verb, has, lacks = STEPS[k]
        want = f"sizefx {verb}" + (f" with {has}" if has else "") + (f" without {lacks}" if lacks else "")
        raise AssertionError(f"README walk-through lacks '{want}' (in order: {', '.join(s[0] for s in STEPS)})")


def option(argv: list, name: str) -> str:
    assert name in argv, f"{shlex.join(argv)}: needs {name}"
    return argv[argv.index(name) + 1]


def run(argv: list, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([str(SIZEFX), *argv[1:]], cwd=cwd, capture_output=True, text=True, timeout=300)


# --------------------------------------------------------------------------- the parser and the steps


def test_parser_reads_continuations_comments_and_every_block():
    text = (
        "intro\n```sh\nnot this\n```\n" + START + " x -->\ntext\n```sh\nsizefx a b \\\n    --c 'd e'  # why\n"
        "\n# a comment line\nsizefx f\n```\nmore text\n```python\nnot sh\n```\n```sh\nsizefx g\n```\n"
        + END
        + "\n```sh\nsizefx after\n```\n"
    )
    assert readme_commands(text) == [["sizefx", "a", "b", "--c", "d e"], ["sizefx", "f"], ["sizefx", "g"]]
    with pytest.raises(AssertionError, match="markers"):
        readme_commands("no markers")


def test_parser_gives_each_command_block_the_output_shown_after_it():
    text = (
        START + " -->\n```sh\nsizefx a\nsizefx b\n```\n```text\nout  of   a\n\n...\nb, ... done\n```\ntext\n"
        "```text\nmore\n```\n```sh\nsizefx c\n```\n" + END
    )
    assert readme_walk(text) == [
        ([["sizefx", "a"], ["sizefx", "b"]], ["out of a", "b, ... done", "more"]),
        ([["sizefx", "c"]], []),
    ]
    with pytest.raises(AssertionError, match="before any command"):
        readme_walk(START + " -->\n```text\nout\n```\n```sh\nsizefx a\n```\n" + END)


def test_a_shown_line_must_be_printed_as_shown():
    printed = "wrote x.h5: 12001 samples,   120.00 s\n  kernel 0.03 s, final 0.6277 m\nsolution -> x.h5\n"
    shown = ["wrote x.h5: 12001 samples, 120.00 s", "kernel ..., final 0.6277 m", "solution -> x.h5"]
    assert not_printed(shown, printed) == []
    assert not_printed(["samples, 120.00 s"], printed) == []  # a part of a line is shown as it is printed
    # the check bites: a changed digit, a wrong order around an elision, a line pieced from two lines
    assert not_printed(["final 0.6278 m"], printed) == ["final 0.6278 m"]
    assert not_printed(["final ... kernel"], printed) == ["final ... kernel"]
    assert not_printed(["120.00 s kernel 0.03 s"], printed) == ["120.00 s kernel 0.03 s"]


def test_every_command_block_shows_what_it_prints():
    walk = readme_walk(README.read_text("utf-8"))
    bare = [shlex.join(commands[0]) for commands, shown in walk if commands and not shown]
    assert not bare, f"README shows no output after: {bare}"


def test_readme_walkthrough_has_every_step():
    commands = readme_commands(README.read_text("utf-8"))
    check_steps(commands)
    # the check bites: each step removed in turn is named as missing
    for k in range(len(commands)):
        with pytest.raises(AssertionError, match="lacks"):
            check_steps(commands[:k] + commands[k + 1 :])


# --------------------------------------------------------------------------- the walk-through, run


@pytest.fixture(scope="module")
def walkthrough(tmp_path_factory):
    """Run every README command in order in a fresh folder; ``(folder, [(argv, result)])``."""
    cwd = tmp_path_factory.mktemp("own")
    (cwd / "examples").symlink_to(EXAMPLES, target_is_directory=True)
    done = []
    for argv in readme_commands(README.read_text("utf-8")):
        result = run(argv, cwd)
        done.append((argv, result))
        if result.returncode != 0:
            break  # the rest depends on this one
    return cwd, done


def find_step(done: list, verb: str, has: str | None = None, lacks: str | None = None):
    """The walk's ``(argv, result)`` of ``sizefx VERB`` (with option ``has``, without ``lacks``), from
    the steps ``done`` (``[(argv, result)]``); AssertionError when it did not run."""
    for argv, result in done:
        if (
            " ".join(argv[1:]).startswith(verb)
            and (has is None or has in argv)
            and (lacks is None or lacks not in argv)
        ):
            return argv, result
    raise AssertionError(f"no 'sizefx {verb}' ran")


def _step(walkthrough, verb: str, has: str | None = None, lacks: str | None = None):
    return find_step(walkthrough[1], verb, has, lacks)


@pytest.fixture(scope="module")
def truth():
    sim = json.loads((EXAMPLES / "tumble_truth.json").read_text("utf-8"))["simulation"]["effects"]
    return {"r_m": np.array(sim["lever_arm"]["r_m"]), "tau_s": sim["accel_delay"]["tau_s"]}


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_readme_walkthrough_has_every_step and each command's own tests (the README's import in tests/test_import_csv.py)
@pytest.mark.slow
def test_every_command_exits_0(walkthrough):
    _, done = walkthrough
    assert len(done) == len(readme_commands(README.read_text("utf-8")))
    for argv, result in done:
        assert result.returncode == 0, f"{shlex.join(argv)} -> {result.returncode}: {result.stderr.strip()}"


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_readme_walkthrough_has_every_step and each command's own tests (the README's import in tests/test_import_csv.py)
@pytest.mark.slow
def test_import_keeps_the_reference_and_reports_the_occlusion(walkthrough):
    cwd, _ = walkthrough
    argv, result = _step(walkthrough, "import csv")
    assert "12001 rates samples at 100 Hz" in result.stdout
    assert "reference rows: 5998 (1 dropouts)" in result.stdout, result.stdout
    with h5py.File(cwd / option(argv, "-o"), "r") as h5:
        assert h5["/reference/quaternion"].shape == (5998, 4) and "/reference/velocity" in h5
        assert h5["/source"].attrs["reference_dropout_rows"] == 3


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_readme_walkthrough_has_every_step and each command's own tests (the README's import in tests/test_import_csv.py)
@pytest.mark.slow
def test_inspect_shows_the_reference(walkthrough):
    _, result = _step(walkthrough, "inspect")
    assert "reference 5998 samples at 50 Hz: attitude + position + velocity" in result.stdout, result.stdout
    assert "dropouts  1 in /reference/time at row 3000 (t = 59.980000 s, 80 ms)" in result.stdout


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_readme_walkthrough_has_every_step and each command's own tests (the README's import in tests/test_import_csv.py)
@pytest.mark.slow
def test_diagnose_names_the_two_hidden_effects(walkthrough, truth):
    cwd, _ = walkthrough
    argv, result = _step(walkthrough, "diagnose")
    report = json.loads((cwd / option(argv, "--json")).read_text())
    found = {(e["id"], e["channel"]): e for e in report["effects"]}
    assert set(found) == {("accel_delay", None), ("lever_arm", "accel_y")}, list(found)
    delay = found[("accel_delay", None)]
    assert abs(delay["parameters"]["tau_s"] - truth["tau_s"]) < DIAGNOSE_Z * delay["sigma"]["tau_s"]
    arm = found[("lever_arm", "accel_y")]
    z = (np.array(arm["parameters"]["r_m"]) - truth["r_m"][1]) / np.array(arm["sigma"]["r_m"])
    assert np.all(np.abs(z) < DIAGNOSE_Z), z
    # the values are judged by their z-scores above; the printed words name them
    assert "accelerometers lag the gyros" in result.stdout and "accelerometer y sits" in result.stdout


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_readme_walkthrough_has_every_step and each command's own tests (the README's import in tests/test_import_csv.py)
@pytest.mark.slow
def test_calibrate_recovers_the_arms_and_the_delay(walkthrough, truth):
    cwd, _ = walkthrough
    argv, _ = _step(walkthrough, "calibrate")
    levers = json.loads((cwd / option(argv, "--json")).read_text())
    arms = np.array([levers["r_x"], levers["r_y"], levers["r_z"]])
    sigma = np.array([levers["sigma_x"], levers["sigma_y"], levers["sigma_z"]])
    assert np.max(np.abs(arms - truth["r_m"]) / sigma) < ARM_Z, (arms - truth["r_m"]) / sigma
    assert abs(levers["accel_delay_s"] - truth["tau_s"]) < DELAY_TOL_S


def _final_error_m(stdout: str) -> float:
    match = re.search(r"horizontal error: final ([0-9.]+) m", stdout)
    assert match, stdout
    return float(match.group(1))


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_readme_walkthrough_has_every_step and each command's own tests (the README's import in tests/test_import_csv.py)
@pytest.mark.slow
def test_the_calibrated_arms_make_navigation_better(walkthrough):
    _, plain = _step(walkthrough, "navigate", lacks="--levers")
    _, compensated = _step(walkthrough, "navigate", has="--levers")
    e_plain, e_comp = _final_error_m(plain.stdout), _final_error_m(compensated.stdout)
    assert e_comp < COMPENSATED_MAX_M and e_plain > PLAIN_MIN_M and e_plain > GAIN_MIN * e_comp, (e_plain, e_comp)


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_readme_walkthrough_has_every_step and each command's own tests (the README's import in tests/test_import_csv.py)
@pytest.mark.slow
def test_compare_agrees_with_navigate(walkthrough):
    cwd, _ = walkthrough
    argv, result = _step(walkthrough, "compare")
    figures = {c["label"]: c for c in json.loads((cwd / option(argv, "--json")).read_text())["comparisons"]}
    a_ref, b_ref = figures["A vs REF"]["horizontal_m"]["final"], figures["B vs REF"]["horizontal_m"]["final"]
    assert a_ref < COMPENSATED_MAX_M and b_ref > GAIN_MIN * a_ref, (a_ref, b_ref)
    _, compensated = _step(walkthrough, "navigate", has="--levers")
    assert a_ref == pytest.approx(_final_error_m(compensated.stdout), rel=0.01)


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_readme_walkthrough_has_every_step and each command's own tests (the README's import in tests/test_import_csv.py)
@pytest.mark.slow
def test_a_wrong_column_in_the_import_fails(walkthrough, tmp_path):
    argv, _ = _step(walkthrough, "import csv")
    (tmp_path / "examples").symlink_to(EXAMPLES, target_is_directory=True)
    wrong = [a.replace("qz", "q_z") if a.startswith("qw,") else a for a in argv]
    assert wrong != argv
    result = run(wrong, tmp_path)
    assert result.returncode == 2 and "column 'q_z' is not in the header" in result.stderr


# long tier: the README's own-recording walk, every command end to end (9 s); fast twin: test_every_command_block_shows_what_it_prints and test_a_shown_line_must_be_printed_as_shown
@pytest.mark.slow
def test_the_shown_output_is_what_the_commands_print(walkthrough):
    _, done = walkthrough
    walk = readme_walk(README.read_text("utf-8"))
    assert len(done) == sum(len(commands) for commands, _ in walk), "a command failed: test_every_command_exits_0"
    results = iter(done)
    for commands, shown in walk:
        printed = "".join(r.stdout + "\n" + r.stderr + "\n" for _, r in (next(results) for _ in commands))
        missing = not_printed(shown, printed)
        assert not missing, (
            f"README shows after `{shlex.join(commands[-1])}` lines it does not print: {missing}; "
            f"it printed:\n{printed}"
        )


# --------------------------------------------------------------------------- the example files


# long tier: regenerates the example's files (1.5 s); the walkthrough's fast checks read them
# (test_parser_reads_continuations_comments_and_every_block, test_example_folder_is_small)
@pytest.mark.slow
def test_example_regenerates_bit_for_bit(tmp_path):
    subprocess.run([sys.executable, str(EXAMPLES / "make_example.py"), "--out", str(tmp_path)], check=True, timeout=300)
    for name in EXAMPLE_FILES:
        assert (tmp_path / name).read_bytes() == (EXAMPLES / name).read_bytes(), name


def test_example_folder_is_small():
    total = sum(p.stat().st_size for p in EXAMPLES.iterdir() if p.is_file())
    assert total < EXAMPLE_MAX_BYTES, total
