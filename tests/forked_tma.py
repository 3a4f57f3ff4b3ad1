"""``tma`` for the documents' shell blocks, as a fork of a process that has imported it already.

tests/test_docs_run.py runs about ninety ``tma`` commands; as processes of their own each pays
the imports of the command (numpy, scipy, pandas, matplotlib, numba, tmakit: about 1 s of CPU)
before it does its work (0.2-0.3 s for most). Here one server a pytest worker imports them
once; each command is a fork of it that runs the same ``tmakit.cli.main`` with the shell's
arguments, working folder, environment and standard streams (the file descriptors themselves,
passed over a Unix socket: a pipe, a redirection to a file or ``/dev/null`` alike) and ends
with the command's own exit status or signal. What a separate process adds, the console script
and a cold start, is tested by tests/test_cli_startup.py, tests/test_faults.py and CI's
``tma demo``.

``python forked_tma.py serve SOCKET`` starts a server; ``python forked_tma.py run SOCKET ARGS``
is the client the shell's ``tma`` calls (standard library only: it starts in a few ms).
"""

from __future__ import annotations

import gc
import json
import os
import signal
import socket
import struct
import sys
from pathlib import Path

TMA = str(Path(sys.executable).parent / "tma")  # the console script's path: argv[0], sys.path[0]
HEADER = struct.Struct("!I")


def run_client(path: str, args: list[str]) -> None:
    """Send the arguments, folder, environment and fds 0-2; end as the command ended."""
    payload = json.dumps({"argv": args, "cwd": os.getcwd(), "env": dict(os.environ)}).encode()
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.connect(path)
        socket.send_fds(sock, [HEADER.pack(len(payload))], [0, 1, 2])
        sock.sendall(payload)
        sock.shutdown(socket.SHUT_WR)
        reply = b"".join(iter(lambda: sock.recv(64), b"")).decode().split()
    if not reply:
        sys.exit("forked tma: the server ended the command without a status")
    how, number = reply[0], int(reply[1])
    if how == "signal":  # as the shell sees a process killed by it: 128 + N
        signal.signal(number, signal.SIG_DFL)
        os.kill(os.getpid(), number)
    os._exit(number)


def serve(path: str) -> None:
    """Import the command, then fork one supervisor a connection until SIGTERM.

    The server also ends when its standard input ends: the test process that started it with
    a pipe there has gone, so no server outlives a killed run.
    """
    import selectors

    from numba_lock import NUMBA_LOCK_VARIABLE, compile_one_at_a_time

    import tmakit.cli  # noqa: F401  (the command and what it imports on every run)

    for name in ("numpy", "scipy.linalg", "scipy.optimize", "scipy.stats", "pandas", "numba",
                 "matplotlib.pyplot", "tmakit.io", "tmakit.batch", "tmakit.filters",
                 "tmakit.tracking", "tmakit.results"):
        __import__(name)  # what most commands import later: loaded once here
    if os.environ.get(NUMBA_LOCK_VARIABLE):  # the forks compile one at a time with pytest's
        compile_one_at_a_time(Path(os.environ[NUMBA_LOCK_VARIABLE]))  # workers
    gc.freeze()  # what the forks share, out of their collections (tma's exit collects)
    sys.path[0] = str(Path(TMA).parent)  # as the console script has it
    supervisors: set[int] = set()

    def stop(_signum, _frame):
        for pid in supervisors:  # waited for: their CPU counts in the suite's
            try:
                os.waitpid(pid, 0)
            except ChildProcessError:
                pass
        os._exit(0)

    signal.signal(signal.SIGTERM, stop)
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as listener:
        listener.bind(path)
        listener.listen(8)
        print("ready", flush=True)
        ready = selectors.DefaultSelector()
        ready.register(listener, selectors.EVENT_READ)
        ready.register(sys.stdin.fileno(), selectors.EVENT_READ)
        while True:
            events = [key.fileobj for key, _ in ready.select()]
            if sys.stdin.fileno() in events and not os.read(sys.stdin.fileno(), 512):
                stop(None, None)
            if listener not in events:
                continue
            conn, _ = listener.accept()
            pid = os.fork()
            if pid == 0:
                listener.close()
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                supervise(conn)
            conn.close()
            supervisors.add(pid)
            for done in [p for p in supervisors if os.waitpid(p, os.WNOHANG)[0]]:
                supervisors.discard(done)


def supervise(conn: socket.socket) -> None:
    """Fork the command, wait for it and send back how it ended (never returns)."""
    head, fds, _, _ = socket.recv_fds(conn, HEADER.size, 3)
    (size,) = HEADER.unpack(head)
    payload = b""
    while len(payload) < size:
        payload += conn.recv(size - len(payload))
    pid = os.fork()
    if pid == 0:
        conn.close()
        run_command(json.loads(payload), fds)
    for fd in fds:
        os.close(fd)
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status):
        conn.sendall(f"signal {os.WTERMSIG(status)}".encode())
    else:
        conn.sendall(f"exit {os.WEXITSTATUS(status)}".encode())
    conn.close()
    os._exit(0)


def run_command(request: dict, fds: list[int]) -> None:
    """Become the client's ``tma``: its streams, folder, environment and arguments."""
    import atexit
    import traceback

    for target, fd in enumerate(fds):
        os.dup2(fd, target)
    for fd in fds:
        if fd > 2:
            os.close(fd)
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    sys.stdout.reconfigure(line_buffering=os.isatty(1))
    sys.argv = [TMA, *request["argv"]]
    code = 0
    try:
        from tmakit.cli import main

        main()
    except SystemExit as stop:  # as the interpreter ends on it
        if stop.code is None or isinstance(stop.code, int):
            code = stop.code or 0
        else:
            print(stop.code, file=sys.stderr)
            code = 1
    except BaseException:  # as the interpreter prints an uncaught one
        traceback.print_exc()
        code = 1
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except OSError:
            code = code or 120  # as the interpreter does when it cannot flush at exit
    os._exit(code)


if __name__ == "__main__":
    if sys.argv[1] == "serve":
        serve(sys.argv[2])
    else:
        run_client(sys.argv[2], sys.argv[3:])
