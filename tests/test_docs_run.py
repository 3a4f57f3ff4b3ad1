"""Every shell command and Python snippet in README.md and docs/*.md runs as written.

The one doc runner. Each document (or each of its sessions, below) is run on its own, in a fresh
empty folder, its blocks in the order they appear, as a reader would paste them:

- ```` ```python ```` blocks share one interpreter namespace per session;
- ```` ```bash ```` (or ``sh``, ``shell``) blocks run as a script with ``bash -e -o pipefail``:
  every line must succeed;
- ```` ```console ```` blocks run their ``$ `` lines (a line ending in ``\\`` continues on the
  next); the other lines are the output a reader sees, and are not compared;
- any other block (``text``, ``toml``, ``csv``, ``json``, …) is not run;
- a runnable block right after an HTML comment ``<!-- not run: REASON -->`` is skipped; the
  reason is required, and the skipped blocks are counted (``python tests/test_docs_run.py``
  prints the inventory);
- a runnable block right after ``<!-- slow: REASON -->`` (a study of minutes, too long for the
  five-minute suite) runs, in its place in the document, only when ``TMAKIT_SLOW_DOCS=1``:
  ``TMAKIT_SLOW_DOCS=1 python -m pytest tests/test_docs_run.py`` runs every such block too;
- a runnable block right after ``<!-- new session -->`` starts a new session: it and the blocks
  after it (to the next such comment) run as a reader starting there would paste them, in a
  fresh folder and a fresh Python namespace, as a test of their own (so that pytest-xdist runs a
  long document's sessions side by side). ``<!-- new session: given `COMMAND` -->`` first runs
  ``COMMAND`` (several: `` `A`, `B` ``), which must be a line of an earlier block of the same
  document (the file the session reads, written as the document writes it).

The folder is empty but for a link ``benchmarks`` to the checkout's ``benchmarks/`` (the docs
run ``python benchmarks/….py`` from a checkout, as the README says). Shell blocks find
``python``, ``python3`` and ``tma`` of the interpreter running the tests, and draw with
matplotlib's Agg backend. Their ``tma`` is a fork of a server that has imported the command
once (tests/forked_tma.py: the same ``main``, arguments, folder, environment, streams and exit
status, without a second of imports for each of the ~90 commands); ``TMAKIT_DOCS_TMA=process``
runs each as a process of its own instead.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
PYTHON = {"python", "py", "python3"}
SHELL = {"bash", "sh", "shell"}
CONSOLE = {"console", "shell-session"}
RUNNABLE = PYTHON | SHELL | CONSOLE
FENCE = re.compile(r"^(?P<indent> *)(?P<fence>`{3,}|~{3,})(?P<info>[^\n`]*)$")  # in lists too
NOT_RUN = re.compile(r"^<!--\s*not run\s*:(?P<reason>.*?)-->\s*$", re.S)
SLOW = re.compile(r"^<!--\s*slow\s*:(?P<reason>.*?)-->\s*$", re.S)
NEW_SESSION = re.compile(r"^<!--\s*new session\s*(?::\s*given\s*(?P<given>`.*`))?\s*-->\s*$",
                         re.S)
RUN_SLOW = os.environ.get("TMAKIT_SLOW_DOCS") == "1"
BLOCK_TIMEOUT_S = 600
FORKED_TMA = Path(__file__).with_name("forked_tma.py")


@dataclass(frozen=True)
class Block:
    """One fenced block of a document."""

    doc: Path
    line: int  # of the opening fence, 1-based
    lang: str
    code: str
    skip_reason: str | None  # None: runs (if runnable); "" : a `not run` comment without reason
    slow_reason: str | None = None  # a `slow` block: runs only with TMAKIT_SLOW_DOCS=1
    given: tuple[str, ...] | None = None  # starts a new session after these commands (or none)

    @property
    def skipped(self) -> bool:
        """Not run in this session: a `not run` block, or a `slow` one without the variable."""
        return self.skip_reason is not None or (self.slow_reason is not None and not RUN_SLOW)

    @property
    def where(self) -> str:
        doc = self.doc.relative_to(ROOT) if self.doc.is_relative_to(ROOT) else self.doc
        return f"{doc}:{self.line}"


def blocks(doc: Path) -> list[Block]:
    """The fenced blocks of ``doc``, in order, with the `not run` comment before each."""
    lines = doc.read_text(encoding="utf-8").splitlines()
    found: list[Block] = []
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, info = m.group("fence"), m.group("info").strip()
        end = i + 1
        while end < len(lines) and not (lines[end].strip().startswith(fence[0] * len(fence))
                                         and lines[end].strip().strip(fence[0]) == ""):
            end += 1
        indent = len(m.group("indent"))
        code = "\n".join(ln[indent:] if not ln[:indent].strip() else ln.lstrip()
                         for ln in lines[i + 1:end]) + "\n"
        found.append(Block(doc, i + 1, info.split()[0].lower() if info else "", code,
                           _skip_reason(lines, i), _skip_reason(lines, i, SLOW),
                           _new_session(lines, i)))
        i = end + 1
    return found


def _comment_before(lines: list[str], fence_index: int) -> str | None:
    """The HTML comment just before a fence (blank lines between allowed), if any."""
    j = fence_index - 1
    while j >= 0 and not lines[j].strip():
        j -= 1
    if j < 0 or not lines[j].rstrip().endswith("-->"):
        return None
    k = j
    while k >= 0 and "<!--" not in lines[k]:
        k -= 1
    return "\n".join(lines[k:j + 1]).strip() if k >= 0 else None


def _skip_reason(lines: list[str], fence_index: int, marker: re.Pattern = NOT_RUN) -> str | None:
    """The reason of a `<!-- not run: … -->` (or ``marker``) comment just before a fence."""
    comment = _comment_before(lines, fence_index)
    m = marker.match(comment) if comment is not None else None
    return None if m is None else " ".join(m.group("reason").split())


def _new_session(lines: list[str], fence_index: int) -> tuple[str, ...] | None:
    """The commands of a `<!-- new session: given `…` -->` comment just before a fence."""
    comment = _comment_before(lines, fence_index)
    m = NEW_SESSION.match(comment) if comment is not None else None
    if m is None:
        return None
    return tuple(" ".join(c.split()) for c in re.findall(r"`([^`]+)`", m.group("given") or ""))


def console_commands(code: str) -> list[str]:
    """The ``$ `` commands of a console block, continuation lines joined."""
    commands: list[str] = []
    current: list[str] | None = None
    for ln in code.splitlines():
        if current is not None:
            current.append(ln)
        elif ln.startswith("$ "):
            current = [ln[2:]]
        else:
            continue
        if not ln.endswith("\\"):
            commands.append("\n".join(current))
            current = None
    if current is not None:
        commands.append("\n".join(current))
    return commands


def shell_env() -> dict[str, str]:
    env = dict(os.environ)
    env["MPLBACKEND"] = "Agg"
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    return env


def run_shell(block: Block, script: str, cwd: Path, tma_socket: Path | None = None) -> None:
    # `python` and `python3` are the interpreter running the tests, whatever the PATH holds.
    prelude = f'python() {{ "{sys.executable}" "$@"; }}\npython3() {{ "{sys.executable}" "$@"; }}\n'
    if tma_socket is not None:
        prelude += f'tma() {{ "{sys.executable}" "{FORKED_TMA}" run "{tma_socket}" "$@"; }}\n'
    try:
        done = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", prelude + script],
                              cwd=cwd, env=shell_env(), capture_output=True, text=True,
                              timeout=BLOCK_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{block.where}: ```{block.lang} block ran over {BLOCK_TIMEOUT_S} s:\n{script}")
    if done.returncode != 0:
        pytest.fail(f"{block.where}: ```{block.lang} block failed (exit {done.returncode}):\n"
                    f"{script}\n--- stdout (tail) ---\n{done.stdout[-3000:]}\n"
                    f"--- stderr (tail) ---\n{done.stderr[-3000:]}")


def run_python(block: Block, namespace: dict) -> None:
    # Pad with blank lines so a traceback names the document's own line numbers.
    code = compile("\n" * block.line + block.code, str(block.doc), "exec")
    try:
        exec(code, namespace)
    except Exception as exc:  # report which block of which document, then the error
        raise AssertionError(f"{block.where}: ```python block failed: "
                             f"{type(exc).__name__}: {exc}\n{block.code}") from exc


def sessions(doc: Path) -> list[list[Block]]:
    """The blocks of ``doc`` that run, in order, split where a `new session` comment starts one."""
    found: list[list[Block]] = []
    for block in blocks(doc):
        if block.lang not in RUNNABLE or block.skipped:
            continue
        if not found or block.given is not None:
            found.append([])
        found[-1].append(block)
    return found


def shell_lines(block: Block) -> list[str]:
    """The commands of a shell or console block, one a line, spaces normalised."""
    if block.lang in CONSOLE:
        code = console_commands(block.code)
    elif block.lang in SHELL:
        code = block.code.replace("\\\n", " ").splitlines()
    else:
        return []
    return [" ".join(ln.split()) for ln in code if ln.strip()]


def run_session(session: list[Block], cwd: Path, tma_socket: Path | None = None) -> None:
    """Run one session's blocks in order in the folder ``cwd``, its given commands first.

    ``tma_socket``: a server of tests/forked_tma.py that runs the shell blocks' ``tma``.
    """
    namespace: dict = {"__name__": "__main__"}
    for command in session[0].given or ():
        run_shell(session[0], command, cwd, tma_socket)
    for block in session:
        if block.lang in PYTHON:
            run_python(block, namespace)
        elif block.lang in SHELL:
            run_shell(block, block.code, cwd, tma_socket)
        else:
            for command in console_commands(block.code):
                run_shell(block, command, cwd, tma_socket)


@pytest.fixture(scope="module")
def tma_socket(tmp_path_factory):
    """A server of tests/forked_tma.py for this worker's sessions (None: a process a command)."""
    if os.environ.get("TMAKIT_DOCS_TMA") == "process":
        yield None
        return
    folder = tmp_path_factory.mktemp("tma")
    path = folder / "socket"
    with open(folder / "stderr", "w+") as err:
        server = subprocess.Popen([sys.executable, str(FORKED_TMA), "serve", str(path)],
                                  cwd=folder, env=shell_env(), stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, stderr=err, text=True)
        try:
            if server.stdout.readline().strip() != "ready":
                server.wait(timeout=60)
                err.seek(0)
                pytest.fail(f"the forked tma server did not start:\n{err.read()[-3000:]}")
            yield path
        finally:
            server.stdin.close()  # it ends when its input ends, once its commands have ended
            try:
                server.wait(timeout=120)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
            server.stdout.close()


def runnable_sessions() -> list:
    """One pytest parameter a session, named by its document and its first block's line."""
    return [pytest.param(session, id=f"{doc.name}:{session[0].line}")
            for doc in DOCS for session in sessions(doc)]


@pytest.mark.long
@pytest.mark.parametrize("session", runnable_sessions())
def test_every_block_of_the_session_runs_in_order(session, tmp_path, monkeypatch, tma_socket):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    (tmp_path / "benchmarks").symlink_to(ROOT / "benchmarks", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    try:
        run_session(session, tmp_path, tma_socket)
    finally:
        plt.close("all")


def test_every_block_names_its_language_and_every_skip_its_reason():
    problems = []
    for doc in DOCS:
        for b in blocks(doc):
            if not b.lang:
                problems.append(f"{b.where}: a fenced block without a language (```text, "
                                "```bash, ```python, …): say whether it runs")
            if b.skip_reason == "" or b.slow_reason == "":
                problems.append(f"{b.where}: `<!-- not run: -->` or `<!-- slow: -->` without "
                                "a reason")
            if (b.skip_reason is not None or b.slow_reason is not None) \
                    and b.lang not in RUNNABLE:
                problems.append(f"{b.where}: `not run` or `slow` before a ```{b.lang} block, "
                                "which never runs")
            if b.given is not None and b.lang not in RUNNABLE:
                problems.append(f"{b.where}: `new session` before a ```{b.lang} block, "
                                "which never runs")
        problems += given_problems(doc)
    assert problems == [], "\n".join(problems)


def given_problems(doc: Path) -> list[str]:
    """A session's given command that is no line of an earlier block of ``doc`` that runs."""
    problems, earlier = [], set()
    for session in sessions(doc):
        problems += [f"{session[0].where}: `new session: given `{c}`` is no line of an earlier "
                     "block: the session would read a file the document does not write"
                     for c in session[0].given or () if c not in earlier]
        for b in session:
            earlier.update(shell_lines(b))
    return problems


def test_a_new_session_comment_starts_a_session_after_commands_of_the_document(tmp_path):
    doc = tmp_path / "d.md"
    doc.write_text("```bash\ntma simulate x  -o a.csv\n```\n\n```python\nx = 1\n```\n"
                   "<!-- new session -->\n```python\ny = 2\n```\n\n"
                   "<!-- new session: given `tma simulate x -o a.csv`, `touch b` -->\n"
                   "```bash\ncat a.csv b\n```\n")
    found = sessions(doc)
    assert [[b.line for b in s] for s in found] == [[1, 5], [9], [14]]
    assert [s[0].given for s in found] == [None, (), ("tma simulate x -o a.csv", "touch b")]
    assert given_problems(doc) == [f"{doc}:14: `new session: given `touch b`` is no line of "
                                   "an earlier block: the session would read a file the "
                                   "document does not write"]


def test_console_commands_join_continuation_lines():
    code = "$ tma a \\\n    --b 1\noutput line\n$ tma c\n"
    assert console_commands(code) == ["tma a \\\n    --b 1", "tma c"]


def test_a_not_run_comment_skips_the_next_block_only(tmp_path):
    doc = tmp_path / "d.md"
    doc.write_text("<!-- not run: needs a radio -->\n\n```bash\nexit 1\n```\n\n```python\n"
                   "x = 1\n```\n<!-- not run: -->\n```python\nraise SystemExit\n```\n")
    found = blocks(doc)
    assert [b.skip_reason for b in found] == ["needs a radio", None, ""]
    assert [b.line for b in found] == [3, 7, 11]


def test_a_slow_comment_marks_the_next_block_to_run_only_on_request(tmp_path):
    doc = tmp_path / "d.md"
    doc.write_text("<!-- slow: a long study -->\n```bash\nsleep 600\n```\n\n```bash\ntrue\n```\n")
    slow, plain = blocks(doc)
    assert (slow.slow_reason, slow.skip_reason, plain.slow_reason) == ("a long study", None, None)
    assert slow.skipped is not RUN_SLOW and not plain.skipped


def test_a_block_in_a_list_item_is_found_and_dedented(tmp_path):
    doc = tmp_path / "d.md"
    doc.write_text("1. Simulate:\n\n    ```bash\n    tma scenarios\n    ```\n\n"
                   "```python\nfor k in range(2):\n    print(k)\n```\n")
    listed, top = blocks(doc)
    assert (listed.lang, listed.code) == ("bash", "tma scenarios\n")
    assert top.code == "for k in range(2):\n    print(k)\n"  # indentation kept


def commands(block: Block) -> int:
    """Shell commands in a block (continuation lines joined, comments and blank lines not)."""
    if block.lang in CONSOLE:
        return len(console_commands(block.code))
    if block.lang in SHELL:
        text = block.code.replace("\\\n", " ")
        return sum(1 for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#"))
    return 0


def inventory() -> list[tuple[str, int, int, int, int, list[str]]]:
    """Per document: Python blocks and shell commands run, the same not run, and why."""
    rows = []
    for doc in DOCS:
        runnable = [b for b in blocks(doc) if b.lang in RUNNABLE]
        ran = [b for b in runnable if not b.skipped]
        skipped = [b for b in runnable if b.skipped]
        rows.append((str(doc.relative_to(ROOT)),
                     sum(b.lang in PYTHON for b in ran), sum(commands(b) for b in ran),
                     sum(b.lang in PYTHON for b in skipped), sum(commands(b) for b in skipped),
                     [f"{b.where}: {b.skip_reason or 'slow (TMAKIT_SLOW_DOCS=1 runs it): '}"
                      f"{b.slow_reason or ''}" for b in skipped]))
    return rows


if __name__ == "__main__":
    totals = [0, 0, 0, 0]
    print(f"{'document':24s} {'run: python blocks':>18s} {'commands':>9s}   "
          f"{'not run: python':>15s} {'commands':>9s}")
    for name, *counts, reasons in inventory():
        totals = [a + b for a, b in zip(totals, counts, strict=True)]
        print(f"{name:24s} {counts[0]:18d} {counts[1]:9d}   {counts[2]:15d} {counts[3]:9d}")
        for reason in reasons:
            print(f"    not run: {reason}")
    print(f"{'total':24s} {totals[0]:18d} {totals[1]:9d}   {totals[2]:15d} {totals[3]:9d}")


def test_the_forked_tma_writes_and_ends_as_its_own_process_does(tma_socket, tmp_path):
    """Output redirected to a file, an error's message and exit status, standard input."""
    if tma_socket is None:
        pytest.skip("TMAKIT_DOCS_TMA=process: every command is its own process already")
    script = ("tma scenarios > list.txt\nstatus=0\ntma estimate missing.csv 2> err.txt "
              "|| status=$?\necho $status > status.txt\n"
              "printf 'time,sensor\\n1,a\\n' | tma track --follow - --format csv "
              "--max-updates 1 > stdin.txt 2> /dev/null || echo \"exit $?\" >> stdin.txt\n")
    out = {}
    for mode, socket in (("forked", tma_socket), ("process", None)):
        (tmp_path / mode).mkdir()
        run_shell(Block(tmp_path / "t.md", 1, "bash", script, None), script, tmp_path / mode,
                  socket)
        out[mode] = {name: (tmp_path / mode / name).read_text()
                     for name in ("list.txt", "err.txt", "status.txt", "stdin.txt")}
    assert out["forked"] == out["process"]
    assert out["forked"]["status.txt"].strip() == "2" and "missing.csv" in out["forked"]["err.txt"]
    assert "gu2007" in out["forked"]["list.txt"]
    assert "standard input ended" in out["forked"]["stdin.txt"]  # it read the pipe to its end
