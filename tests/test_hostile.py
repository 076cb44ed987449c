"""Hostile input: every crafted file and option value of ``tests/hostile_corpus.py``
against the command line's promises.

Promises checked per case (``docs/telemetry.md``, ``sizefx --help``): exit code 2 for bad input
(0 where the input is odd but legal), exactly one stderr line ``sizefx: error: ...`` naming the
user's file or option (never a temporary file), no traceback, no output or ``*.tmp`` left
behind, every input byte-identical, peak RSS under ``MEMORY_CEILING_BYTES``, an exit within
seconds. Signals: SIGTERM exits 143 and SIGINT 130, both without a ``*.tmp``; a file-size limit
(``ulimit -f``) is a one-line refusal, not a crash.

How they run: each case is one test id (``pytest --full -k gzip-bomb``; the fast tier runs the
first case of each kind). Ordinary cases run click's CliRunner in a forked copy of this process
(no interpreter start-up, a hang is killed at ``IN_PROCESS_LIMIT_S``, peak RSS from
``os.wait4``); memory bombs, hang candidates and signal cases run the installed ``sizefx``
console script. All selected cases run once, two at a time (one at a time per pytest-xdist worker),
in a session fixture; each test then judges its own case. Many cases fail against today's
sizefx: that is what the suite is for.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import hostile_corpus as hc
import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from support import long_tier_selected

#: Hypothesis examples per property: each is one forked run (~0.1-1 s), and the file must stay
#: under a minute on two cores.
EXAMPLES = 12
#: The numeric options' property in the fast tier: its runs include whole navigations (up to 1.5 s
#: each), so it keeps 6 examples there and its long-tier twin draws :data:`LONG_EXAMPLES`.
OPTION_EXAMPLES = 6
LONG_EXAMPLES = 48
#: No shrinking: each example is a forked sizefx run, and shrinking one failure took 106 s
#: (measured); the failure message names the generated case, which is what a developer needs.
PHASES = (Phase.explicit, Phase.reuse, Phase.generate)


def _corpus_root(config) -> Path:
    """Where the corpus is written: under pytest's tmp base (the session's tmp_path_factory),
    once, at collection, so that the case names can parametrize the tests. The fast tier writes
    it without the memory bombs and hang candidates (the slow files to write, and all in the
    long tier)."""
    root = getattr(config, "_hostile_root", None)
    if root is None:
        factory = getattr(config, "_tmp_path_factory", None)
        root = factory.mktemp("hostile") if factory is not None else Path(tempfile.mkdtemp(prefix="hostile-"))
        config._hostile_root = root
        cases = hc.write_corpus(root, resource=long_tier_selected(config))
        config._hostile_cases = {c.name: c for c in cases}
    return root


def _kind(case_name: str) -> str:
    """A case's kind: the first word of its name (``gyro-nan-navigate`` -> ``gyro``)."""
    return case_name.split("-", 1)[0]


def pytest_generate_tests(metafunc):
    """One test per case. The fast tier keeps the first case of each kind (about 40 of 600:
    every reader, writer and refusal path once); the long tier runs them all."""
    if "case_name" in metafunc.fixturenames:
        _corpus_root(metafunc.config)
        names = list(metafunc.config._hostile_cases)
        first_of_kind = {}
        for name in names:
            first_of_kind.setdefault(_kind(name), name)
        fast = set(first_of_kind.values())
        params = [pytest.param(n, marks=() if n in fast else pytest.mark.slow) for n in names]
        metafunc.parametrize("case_name", params, ids=names)


@pytest.fixture(scope="session")
def corpus(request):
    _corpus_root(request.config)
    return request.config._hostile_root, request.config._hostile_cases


class _CaseByCase(dict):
    """Outcomes run one case at a time, when a test first asks for it."""

    def __init__(self, cases, scratch):
        super().__init__()
        self.cases, self.scratch = cases, scratch

    def __missing__(self, name):
        self.update(hc.run_cases([self.cases[name]], self.scratch, workers=1))
        return self[name]


@pytest.fixture(scope="session")
def outcomes(request, corpus, tmp_path_factory):
    """Every selected case's outcome by name: all run once, two at a time, in one process; under
    pytest-xdist each worker runs only the cases it is given, one at a time (the workers are the
    parallelism there)."""
    root, cases = corpus
    hc.warm_imports()
    scratch = tmp_path_factory.mktemp("hostile-runs")
    if os.environ.get("PYTEST_XDIST_WORKER"):
        return _CaseByCase(cases, scratch)
    selected = {
        item.callspec.params["case_name"]
        for item in request.session.items
        if hasattr(item, "callspec") and "case_name" in item.callspec.params
    }
    return hc.run_cases([cases[n] for n in cases if n in selected], scratch)


def test_hostile_case(case_name, corpus, outcomes):
    """One crafted input: the command keeps every promise (the failure lists the broken ones)."""
    _, cases = corpus
    case = cases[case_name]
    if case.skip:
        pytest.skip(case.skip)
    o = outcomes[case_name]
    limit = hc.SUBPROCESS_LIMIT_S if case.resource else hc.IN_PROCESS_LIMIT_S
    broken = hc.broken_promises(o, limit_s=limit)
    assert not broken, hc.describe(o, broken)


# long tier: needs the whole corpus, which only the long tier writes
@pytest.mark.slow
def test_corpus_covers_the_issue(corpus):
    """The kinds of hostile input are all in the corpus, and valid baselines are expected to pass
    (a runner that refused everything would fail those)."""
    _, cases = corpus
    names = " ".join(cases)
    for kind in (
        "soft-link-cycle",
        "hard-link-cycle",
        "deep-groups",
        "samples-1-",
        "samples-5-",
        "accel-time-decreasing",
        "time-last-stamp-zero",
        "time-non-monotonic",
        "accel-nan",
        "gyro-inf",
        "1e300",
        "reference-velocity-1e30",
        "latitude-plus-90",
        "latitude-91",
        "units",
        "strings",
        "shape-n-2",
        "huge-declared-shape",
        "gzip-bomb",
        "truncated",
        "zero-byte",
        "text-named-h5",
        "directory-input",
        "json-deep",
        "toml-deep",
        "invalid-utf8",
        "huge-int",
        "toml-nan",
        "csv-missing-column",
        "csv-nan",
        "csv-non-monotonic",
        "csv-one-row",
        "option-",
        "output-is-the-input",
        "output-and-json-same-path",
        "force-output-is-levers",
        "symlink-output",
        "plots-with-existing",
        "unwritable",
        "missing-directory",
        "samples-5-navigate-plot",
        "samples-10-run-plots",
        "no-reference-position-navigate-output-and-plot",
        "description-not-utf8",
        "gyro-units-not-utf8",
        "group-name-not-utf8",
        "csv-time-in-ms-read-as-s",
        "csv-reference-time-in-ms-read-as-s",
        "csv-site-deg-north-pole",
        "reference-position-lat-90",
        "fleet-out-holds-records",
        "fleet-lock-link-to-record",
        "fleet-record-fifo",
        "fleet-glob-link-loop",
        "fleet-scheduler-unreachable",
    ):
        assert kind in names, f"the corpus lost its {kind!r} cases"
    assert sum(c.expect == hc.ACCEPT for c in cases.values()) >= 5
    # every numeric option of every fuzzed command has its NaN case (click introspection)
    for path, flag, _ in hc.numeric_options():
        assert f"option-{'-'.join(path)}{flag}-nan" in cases, (path, flag)


# --------------------------------------------------------------------------- signals and limits


def _wait_for_tmp(folder: Path, timeout_s: float):
    """Until a ``*.tmp`` appears in ``folder`` (the output is being written) or ``timeout_s``."""
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        if any(p.name.endswith(".tmp") for p in folder.iterdir()):
            return True
        time.sleep(0.02)
    return False


#: Exit codes after a signal, as a shell reports them (128 + signal number): what scripts and
#: schedulers test for; a Python traceback on Ctrl-C is not an answer.
SIGNAL_EXIT = {signal.SIGTERM: 143, signal.SIGINT: 130}
#: A simulate run long enough to be caught mid-write: a 30-minute flight at 1600 Hz (~2.9 M
#: samples, ~25 s of work).
LONG_SIMULATE = ("simulate", "flight", "--duration-h", "0.5", "--rate-hz", "1600", "-q")
#: How long to wait for the output's temporary file before signalling anyway: it appears within
#: about a second on a quiet machine, but a loaded one (the suite under ``-n auto``) can take
#: several seconds to start the interpreter, and a signal before its handlers exist kills it.
TMP_WAIT_S = 20.0


@pytest.mark.parametrize(
    "sig",
    # long tier: SIGINT takes the same path as SIGTERM in the fast tier (the exit code differs)
    [signal.SIGTERM, pytest.param(signal.SIGINT, marks=pytest.mark.slow)],
    ids=["SIGTERM", "SIGINT"],
)
def test_signal_mid_write_leaves_nothing(sig, tmp_path):
    """Killed while writing: the conventional exit code, no traceback, no ``*.tmp``, no output."""
    out = tmp_path / "flight.h5"
    proc = subprocess.Popen(
        [hc.console_script() or "sizefx", LONG_SIMULATE[0], LONG_SIMULATE[1], "-o", str(out), *LONG_SIMULATE[2:]],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    saw_tmp = _wait_for_tmp(tmp_path, TMP_WAIT_S)
    proc.send_signal(sig)
    try:
        stdout, stderr = proc.communicate(timeout=hc.SUBPROCESS_LIMIT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        stdout, stderr = proc.communicate()
        pytest.fail(
            f"{sig.name}: sizefx {' '.join(LONG_SIMULATE)} did not exit within {hc.SUBPROCESS_LIMIT_S} s of the signal"
        )
    left = sorted(p.name for p in tmp_path.iterdir())
    broken = []
    if proc.returncode != SIGNAL_EXIT[sig]:
        got = f"killed by signal {-proc.returncode}" if proc.returncode < 0 else f"exit code {proc.returncode}"
        broken.append(f"exit code: expected {SIGNAL_EXIT[sig]}, got {got}")
    if "Traceback" in stderr + stdout:
        broken.append(f"traceback: {hc.tail(stderr)}")
    if left:
        broken.append(f"no output left: {left}")
    assert not broken, (
        f"case {sig.name}-mid-write (signal sent {'while a .tmp existed' if saw_tmp else f'after {TMP_WAIT_S} s'}):"
        f" {' | '.join(broken)}; stderr: {stderr.strip()[-300:]!r}"
    )


#: The file-size limit of the ``ulimit -f`` case: far below the record simulate writes.
FSIZE_LIMIT_BYTES = 1 << 20


def test_signal_swallowed_by_a_finalizer_prints_no_traceback():
    """A signal landing in a ``__del__`` or weakref callback (h5py closes objects in both) has its
    Interrupted swallowed by Python and printed as "Exception ignored": the command line's hook keeps
    that quiet (``INTERRUPTED`` still records the signal) and reports every other exception."""
    import sys

    from sizefx.errors import Interrupted
    from sizefx_cli.main import _quiet_interrupted

    reported = []

    class Finalizer:
        def __init__(self, exc):
            self.exc = exc

        def __del__(self):
            raise self.exc

    previous, sys.unraisablehook = sys.unraisablehook, _quiet_interrupted(reported.append)
    try:
        Finalizer(Interrupted(signal.SIGTERM))
        Finalizer(ValueError("a real bug"))
    finally:
        sys.unraisablehook = previous
    assert [type(u.exc_value) for u in reported] == [ValueError]


def test_a_signal_turned_into_a_library_error_is_still_the_signal(monkeypatch):
    """A signal landing inside h5py's attribute write comes out as h5py's TypeError, not as the
    handler's Interrupted (seen on a loaded machine): still exit 143 and one line, no traceback."""
    from click.testing import CliRunner

    from sizefx.errors import Interrupted
    from sizefx.io.files import INTERRUPTED, interrupt
    from sizefx_cli.main import SizefxGroup

    monkeypatch.setitem(INTERRUPTED, "signum", None)  # the process-wide record, restored afterwards
    group = SizefxGroup("sizefx")

    @group.command("write")
    def write():
        try:
            interrupt(signal.SIGTERM, None)
        except Interrupted:
            raise TypeError("Operation not defined for data type class") from None

    result = CliRunner().invoke(group, ["write"])
    assert result.exit_code == 143, result.output
    assert result.output.strip() == "sizefx: terminated (SIGTERM); unfinished outputs removed", result.output


def test_file_size_limit_is_a_one_line_refusal(tmp_path):
    """``ulimit -f 1024``: writing past 1 MiB fails with EFBIG (Python ignores SIGXFSZ). That is
    an output the command cannot write: exit 2, one line naming the output, no ``*.tmp``; not a
    crash (153: SIGXFSZ) or a traceback."""
    out = tmp_path / "tumble.h5"
    argv = ["simulate", "tumble", "-o", str(out), "--duration-s", "60", "--rate-hz", "1600", "-q"]

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (FSIZE_LIMIT_BYTES, FSIZE_LIMIT_BYTES))

    proc = subprocess.run(
        [hc.console_script() or "sizefx", *argv],
        capture_output=True,
        text=True,
        preexec_fn=limit,
        timeout=hc.SUBPROCESS_LIMIT_S * 3,
    )
    left = sorted(p.name for p in tmp_path.iterdir())
    lines = proc.stderr.splitlines()
    broken = []
    if proc.returncode != 2:
        broken.append(f"exit code: expected 2, got {proc.returncode}")
    if "Traceback" in proc.stderr:
        broken.append(f"traceback: {hc.tail(proc.stderr)}")
    if len(lines) != 1 or not lines[0].startswith("sizefx: error:") or str(out) not in lines[0]:
        broken.append(f"one line naming {out}: got {proc.stderr.strip()[-300:]!r}")
    if left:
        broken.append(f"no output left: {left}")
    assert not broken, "case ulimit-f-1MiB: sizefx " + " ".join(argv) + ": " + " | ".join(broken)


# --------------------------------------------------------------------------- hypothesis


_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e300, -1e300, 1e-300, 5e-324, 1e30, np.nan, np.inf, -np.inf]),
)


@settings(max_examples=EXAMPLES, deadline=None, database=None, phases=PHASES, suppress_health_check=list(HealthCheck))
@given(
    dataset=st.sampled_from(sorted(hc.MUTATION_TARGETS)),
    row=st.integers(0, 999),
    col=st.integers(0, 3),
    value=_VALUES,
    command=st.sampled_from(["inspect", "navigate"]),
)
def test_mutated_record_keeps_promises(tmp_path_factory, dataset, row, col, value, command):
    """One value of a valid record replaced (tests/support.py::write_raw): refused with one
    line, or accepted; never a traceback, a hang or a changed input. NaN, inf and time stamps
    out of order must be refused (hc.mutation_expectation)."""
    root = tmp_path_factory.mktemp("mutated")
    name = f"mutated-{dataset.replace('/', '-')}-row{row}-col{col}-{value!r}-{command}"
    case = hc.mutated_value_case(root, name, dataset, row, col, value, command)
    o = hc.run_cases([case], root / "_runs")[name]
    broken = hc.broken_promises(o, limit_s=hc.IN_PROCESS_LIMIT_S)
    assert not broken, hc.describe(o, broken)


_OPTION_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**20), 10**20).map(str),
    st.sampled_from(["nan", "-nan", "+inf", "-Infinity", "1e309", "0", "-0", "1e-320"]),
)


def _numeric_option_keeps_promises(corpus, tmp_path_factory, option, value):
    root, _ = corpus
    path, flag, _kind = option
    name = f"hyp-option-{'-'.join(path)}{flag}-{value[:40]}-{time.monotonic_ns()}"
    case = hc.option_case(root, path, flag, value, name)
    o = hc.run_cases([case], tmp_path_factory.mktemp("option-runs"))[name]
    broken = hc.broken_promises(o, limit_s=hc.IN_PROCESS_LIMIT_S)
    assert not broken, hc.describe(o, broken)


@settings(
    max_examples=OPTION_EXAMPLES, deadline=None, database=None, phases=PHASES, suppress_health_check=list(HealthCheck)
)
@given(option=st.sampled_from(hc.numeric_options()), value=_OPTION_VALUES)
def test_numeric_option_keeps_promises(corpus, tmp_path_factory, option, value):
    """Any value for any numeric option (click introspection): non-finite values are refused
    with one line naming the option; others are refused or run, within the limits."""
    _numeric_option_keeps_promises(corpus, tmp_path_factory, option, value)


@pytest.mark.slow
@settings(
    max_examples=LONG_EXAMPLES, deadline=None, database=None, phases=PHASES, suppress_health_check=list(HealthCheck)
)
@given(option=st.sampled_from(hc.numeric_options()), value=_OPTION_VALUES)
def test_numeric_option_keeps_promises_long(corpus, tmp_path_factory, option, value):
    """The fast tier's property over :data:`LONG_EXAMPLES` examples."""
    _numeric_option_keeps_promises(corpus, tmp_path_factory, option, value)


# long tier: allocates and measures a child's memory (5 s); the fast tier's hostile cases keep their own memory check
@pytest.mark.slow
def test_memory_ceiling_is_measured_per_child(tmp_path):
    """The RSS check can fail: a child that allocates 2 GiB is reported over the ceiling (and
    one that does not, under it), so a bomb case that passes really stayed small."""
    big = hc.Case("probe-big", ("--version",), tmp_path)
    pid = os.fork()
    if pid == 0:
        a = np.ones(2 * 2**30 // 8)
        os._exit(0 if a[-1] == 1.0 else 1)
    _, _, usage = os.wait4(pid, 0)
    assert usage.ru_maxrss * 1024 > hc.MEMORY_CEILING_BYTES, "a 2 GiB child was not seen over the ceiling"
    small = hc.run_cases([big], tmp_path / "_runs")["probe-big"]
    assert small.peak_rss_bytes < hc.MEMORY_CEILING_BYTES and small.exit_code == 0, small
