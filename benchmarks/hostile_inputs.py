"""Hostile inputs against the real code: how long BenchBot takes to refuse each, how much memory it uses meanwhile,
and what it answers.

Three groups, each run against this checkout's real commands, as subprocesses, on 127.0.0.1 only:

* ``server``: one backend started with ``benchbot run --env ENV --task semantic_slam:active:ground_truth --port 0
  --camera-size WxH --no-tui`` (the active task, so that the motion routes exist; the address is read from its
  stderr) receives, each over a fresh socket with the body sent while the reply is read (a client that does not
  wait for the server): ``POST /results_functions/create_object`` asking for 1e8 objects, a 50 MB body on
  ``/connections/move_next``, a native step (MessagePack) asking for 3 million observation names, and
  ``/connections/move_distance`` with a 400-digit number, 1e308 and 1e9. Per request: the status, milliseconds
  from the first byte sent to the end of the reply, the megabytes sent before the server answered and closed
  (socket buffers included), the backend's peak resident memory so far (``VmHWM`` of ``/proc/PID/status`` after
  the request: it only grows, so a request that costs memory shows as a step) and the reply's one-line ``error``.
* ``files``: ``benchbot eval`` on a ~1 MB zip bomb that inflates to 1 GiB, on a zip whose headers say a 1 GiB
  member is 100 bytes, on a sparse 1 GiB results file, on JSON nested 100,000 deep and on a 5,000-digit integer;
  ``benchbot install`` (``--dry-run``, and for real into a temporary ``BENCHBOT_DATA_DIR``) of a pack holding a
  YAML alias bomb (9**12 strings from ~600 bytes). Per case: exit status, wall seconds, the child's peak resident
  memory (``ru_maxrss`` from ``wait4`` in a small launcher: the largest of the process and the children it waited
  for) and the first line of its stderr (the temporary directory's path cut from it).
* ``batch``: ``benchbot batch --native "python -c ..." --envs ENV4 --no-evaluate`` where the solution prints
  1 GiB to stdout (1,048,576 lines of 1 KiB; ``--shout-mib``), then exits without results: exit status, wall seconds,
  peak resident memory (``ru_maxrss``, as above), the size of the episode's log, its last line and the batch's line
  for the episode.

Every child has a timeout (SIGTERM, then SIGKILL 10 s later); the files are built in, and removed with, one
temporary directory, which is also every child's ``BENCHBOT_DATA_DIR``.

    python benchmarks/hostile_inputs.py [--only server,files,batch] [--env miniroom:1] [--batch-env miniroom:4]
                                        [--camera-size 64x48] [--arch cpu] [--shout-mib 1024] [--json] [--smoke]

``--smoke``: every group, with three of the seven files (the zip bomb, the nested JSON, the alias bomb installed)
and a solution that prints 32 MiB (twice the episode log's limit).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shlex
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from hostile_files import alias_bomb, zip_bomb  # noqa: E402 - the builders the security tests use

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
GIB = 1 << 30
MIB = 1 << 20


# ------------------------------------------------------------------------------------------------ children
def child_env(data_dir: Path) -> dict[str, str]:
    """The benchmark's environment for a child: a private data directory, wide lines (no wrapped messages)."""
    return {**os.environ, "BENCHBOT_DATA_DIR": str(data_dir), "COLUMNS": "200"}


MEASURE = """
import os, subprocess, sys, threading, time
report, timeout_s, argv = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
started = time.monotonic()
child = subprocess.Popen(argv)
reaped, timed_out = threading.Event(), []

def stop():
    if reaped.wait(timeout_s):
        return
    timed_out.append(1)
    child.terminate()
    if not reaped.wait(10):
        child.kill()

threading.Thread(target=stop, daemon=True).start()
_, status, usage = os.wait4(child.pid, 0)
reaped.set()
child.returncode = os.waitstatus_to_exitcode(status)
with open(report, "w") as f:
    f.write(f"{child.returncode} {time.monotonic() - started} {usage.ru_maxrss} {len(timed_out)}")
"""
"""Runs ``argv`` (SIGTERM at ``timeout_s``, SIGKILL 10 s later) and writes ``exit wall_s ru_maxrss_kib timed_out``
to ``report``. A small interpreter of its own: a child's ``ru_maxrss`` starts at the resident size of the process
that forked it, so forking from this benchmark (hundreds of MiB after the server group) would hide the child's."""


def run_measured(argv: list[str], env: dict[str, str], timeout_s: float, tmp: Path) -> dict:
    """Run ``argv`` to its end through :data:`MEASURE` (``timeout_s``, then SIGTERM; SIGKILL 10 s later).

    Returns ``{"exit", "wall_s", "peak_rss_mib", "stderr", "timed_out"}``; ``peak_rss_mib`` is the ``ru_maxrss``
    that ``wait4`` reports for that child alone (the largest of it and the children it waited for).
    """
    report = tmp / "measure.txt"
    report.unlink(missing_ok=True)
    with tempfile.TemporaryFile() as err:
        subprocess.run([sys.executable, "-I", "-S", "-c", MEASURE, str(report), str(timeout_s), *argv],
                       stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err, env=env,
                       timeout=timeout_s + 60)
        err.seek(0)
        stderr = err.read().decode(errors="replace")
    code, wall, maxrss, timed_out = report.read_text().split()
    return {"exit": int(code), "wall_s": round(float(wall), 2), "peak_rss_mib": round(int(maxrss) / 1024, 1),
            "stderr": stderr, "timed_out": timed_out == "1"}


def first_line(text: str) -> str:
    """The first non-blank line of ``text``, stripped ('' when there is none)."""
    return next((line.strip() for line in text.splitlines() if line.strip()), "")


# ------------------------------------------------------------------------------------------------ 1. server
class Backend:
    """``benchbot run`` as a subprocess on 127.0.0.1 (any free port); stderr goes to a file read for the address."""

    def __init__(self, args: argparse.Namespace, tmp: Path) -> None:
        self.log = tmp / "backend.stderr"
        argv = [*BENCHBOT, "run", "--env", args.env, "--task", "semantic_slam:active:ground_truth", "--port", "0",
                "--camera-size", args.camera_size, "--no-tui", "--arch", args.arch]
        with open(self.log, "wb") as err:
            self.proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err,
                                         env=child_env(tmp / "data"))
        deadline = time.monotonic() + args.startup_timeout
        while True:
            found = re.search(r"backend ready\S* at http://127\.0\.0\.1:(\d+)", self.log.read_text(errors="replace"))
            if found:
                self.port = int(found.group(1))
                return
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.close()
                raise SystemExit(f"benchbot run did not start:\n{self.log.read_text(errors='replace')[-2000:]}")
            time.sleep(0.2)

    def memory_mib(self) -> tuple[float, float]:
        """``(VmHWM, VmRSS)`` of the backend process in MiB: its peak resident memory so far, and now."""
        fields = dict(line.split(":", 1) for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines())
        return (int(fields["VmHWM"].split()[0]) / 1024, int(fields["VmRSS"].split()[0]) / 1024)

    def close(self) -> None:
        """Ctrl-C, as a user stops it; SIGKILL if it is still there 30 s later."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)


def raw_post(port: int, path: str, body: bytes, content_type: str, timeout_s: float) -> dict:
    """``POST path`` with ``body`` over a fresh socket to 127.0.0.1, the body sent from a thread while the reply is
    read. Returns ``{"status", "ms", "sent_mb", "message"}`` (status 0: the connection ended without a reply)."""
    head = (f"POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: {content_type}\r\n"
            f"Content-Length: {len(body)}\r\nConnection: close\r\n\r\n").encode()
    sent = [0]
    started = time.monotonic()
    with socket.create_connection(("127.0.0.1", port), timeout=timeout_s) as sock:
        def send() -> None:
            view = memoryview(head + body)
            try:
                while sent[0] < len(view):
                    sent[0] += sock.send(view[sent[0]:sent[0] + MIB])
            except OSError:  # the server answered and closed before taking it all
                pass

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        reply = b""
        try:
            while chunk := sock.recv(65536):
                reply += chunk
        except OSError:
            pass
        ms = (time.monotonic() - started) * 1000.0
        try:
            sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        sender.join(timeout_s)
    status_line, _, rest = reply.partition(b"\r\n")
    match = re.match(rb"HTTP/1\.[01] (\d{3})", status_line)
    payload = rest.partition(b"\r\n\r\n")[2]
    try:
        decoded = json.loads(payload)
        if isinstance(decoded, dict):
            message = decoded.get("error") or json.dumps(decoded)[:120]
        else:
            message = str(decoded)[:120]
    except ValueError:
        message = payload[:120].decode(errors="replace")
    return {"status": int(match.group(1)) if match else 0, "ms": round(ms, 1),
            "sent_mb": round(max(sent[0] - len(head), 0) / 1e6, 2), "message": first_line(str(message))}


def server_cases(args: argparse.Namespace, tmp: Path) -> list[dict]:
    """The requests of the ``server`` group against one ``benchbot run`` backend, in order."""
    from benchbot.protocol import wire

    json_type = "application/json"
    requests = [
        ("create_object 1e8 objects", "/results_functions/create_object", b'{"args": [100000000]}', json_type),
        ("50 MB body on move_next", "/connections/move_next", b"{" + b" " * (50_000_000 - 2) + b"}", json_type),
        ("native step, 3e6 observation names", "/native/step",
         wire.pack({"action": None, "observations": ["laser"] * 3_000_000}), wire.MSGPACK_TYPE),
        ("move_distance 400 digits", "/connections/move_distance", b'{"distance": ' + b"9" * 400 + b"}", json_type),
        ("move_distance 1e308", "/connections/move_distance", b'{"distance": 1e308}', json_type),
        ("move_distance 1e9", "/connections/move_distance", b'{"distance": 1e9}', json_type),
    ]
    backend = Backend(args, tmp)
    rows = []
    try:
        hwm, rss = backend.memory_mib()
        rows.append({"case": "backend ready (before any request)", "status": None, "ms": None, "body_mb": None,
                     "sent_mb": None, "peak_rss_mib": round(hwm, 1), "rss_mib": round(rss, 1), "message": ""})
        for name, path, body, content_type in requests:
            row = {"case": name, "body_mb": round(len(body) / 1e6, 2),
                   **raw_post(backend.port, path, body, content_type, args.request_timeout)}
            hwm, rss = backend.memory_mib()
            row.update(peak_rss_mib=round(hwm, 1), rss_mib=round(rss, 1))
            rows.append(row)
    finally:
        backend.close()
    return rows


# ------------------------------------------------------------------------------------------------ 2. files
def file_cases(args: argparse.Namespace, tmp: Path) -> list[dict]:
    """The cases of the ``files`` group: each file built in ``tmp``, then the real command on it."""
    files = tmp / "files"
    files.mkdir()
    bomb = zip_bomb(files / "bomb.zip", "results.json", GIB)
    liar = zip_bomb(files / "liar.zip", "results.json", GIB, declared=100)
    sparse = files / "sparse.json"
    with open(sparse, "wb") as f:
        f.truncate(GIB)  # 1 GiB that costs no disk
    deep = files / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    bigint = files / "bigint.json"
    bigint.write_text('{"task_details": ' + "7" * 5000 + "}")
    pack = files / "bomb_pack"
    (pack / "tasks").mkdir(parents=True)
    (pack / "tasks" / "bomb.yaml").write_text(alias_bomb())
    scores = files / "scores.json"
    cases = [
        (f"eval zip bomb ({bomb.stat().st_size / 1e6:.1f} MB -> 1 GiB)", ["eval", str(bomb), "-o", str(scores)]),
        ("eval zip, header says 100 B (1 GiB)", ["eval", str(liar), "-o", str(scores)]),
        ("eval sparse 1 GiB results file", ["eval", str(sparse), "-o", str(scores)]),
        ("eval JSON nested 100,000 deep", ["eval", str(deep), "-o", str(scores)]),
        ("eval 5,000-digit integer", ["eval", str(bigint), "-o", str(scores)]),
        ("install --dry-run YAML alias bomb", ["install", "--dry-run", str(pack)]),
        ("install YAML alias bomb (temp data dir)", ["install", str(pack)]),
    ]
    if args.smoke:  # one of each kind: an archive, a parser's limit, a content pack
        cases = [case for case in cases if case[0].startswith(("eval zip bomb", "eval JSON nested", "install YAML"))]
    rows = []
    for name, cli_args in cases:
        result = run_measured([*BENCHBOT, *cli_args], child_env(tmp / "data"), args.cli_timeout, tmp)
        rows.append({"case": name, "exit": result["exit"], "wall_s": result["wall_s"],
                     "peak_rss_mib": result["peak_rss_mib"], "timed_out": result["timed_out"],
                     "message": first_line(result["stderr"]).replace(str(files) + os.sep, "")})
        scores.unlink(missing_ok=True)
    return rows


# ------------------------------------------------------------------------------------------------ 3. batch
def shout(mib: int) -> str:
    """The solution: ``mib`` MiB to stdout (1,024 lines of 1 KiB each), then it exits without results."""
    return ("import sys\nline = b'x' * 1023 + b'\\n'\nchunk = line * 1024\n"
            f"for _ in range({mib}):\n    sys.stdout.buffer.write(chunk)\n")


def size_name(mib: int) -> str:
    """``1 GiB`` for 1024, ``32 MiB`` for 32."""
    return f"{mib // 1024} GiB" if mib % 1024 == 0 else f"{mib} MiB"


def batch_case(args: argparse.Namespace, tmp: Path) -> dict:
    """One real batch episode whose solution prints ``--shout-mib`` to stdout; the episode log's size and last
    line."""
    output = tmp / "batch"
    native = shlex.join([sys.executable, "-c", shout(args.shout_mib)])
    result = run_measured([*BENCHBOT, "batch", "--native", native, "--envs", args.batch_env, "--camera-size",
                           args.camera_size, "--arch", args.arch, "--no-evaluate", "--output-dir", str(output)],
                          child_env(tmp / "data"), args.batch_timeout, tmp)
    logs = sorted(output.glob("**/logs/*.log"))
    size = sum(log.stat().st_size for log in logs)
    last = ""
    if logs:
        with open(logs[0], "rb") as f:
            f.seek(max(logs[0].stat().st_size - 4096, 0))
            last = first_line("\n".join(reversed(f.read().decode(errors="replace").splitlines())))
    lines = result["stderr"].splitlines()
    outcome = [line for line in lines if re.match(r"\[\d+/\d+\] |error:", line)]  # the episode's line, or an error
    return {"case": f"solution prints {size_name(args.shout_mib)} ({args.batch_env})", "exit": result["exit"],
            "wall_s": result["wall_s"], "peak_rss_mib": result["peak_rss_mib"], "timed_out": result["timed_out"],
            "logs": len(logs), "log_mib": round(size / MIB, 2), "log_last_line": last,
            "outcome": (outcome[0] if outcome else first_line(result["stderr"])).strip()}


# ------------------------------------------------------------------------------------------------ report
def cell(value) -> str:
    """One table cell: ``-`` for None, floats with two decimals."""
    if value is None:
        return "-"
    return f"{value:.2f}" if isinstance(value, float) else str(value)


def table(rows: list[dict], columns: list[tuple[str, str]]) -> str:
    """``rows`` as an aligned text table of ``columns`` ``(key, heading)``; the last column is left unpadded."""
    cells = [[heading for _, heading in columns]] + [[cell(row.get(k)) for k, _ in columns] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(columns) - 1)]
    lines = []
    for n, r in enumerate(cells):
        lines.append("  ".join([c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))]
                               + [r[-1]]).rstrip())
        if n == 0:
            lines.append("  ".join("-" * w for w in widths) + "  " + "-" * len(r[-1]))
    return "\n".join(lines)


def print_report(report: dict, as_json: bool) -> None:
    """``report`` as one JSON object, or as three tables."""
    if as_json:
        print(json.dumps(report))
        return
    print(f"# {report['machine']}; backend {report['env']} at {report['camera_size']}, arch {report['arch']}")
    if "server" in report:
        print("\n## server: benchbot run on 127.0.0.1 (peak RSS = the backend's VmHWM after the request)\n")
        print(table(report["server"], [("case", "request"), ("status", "status"), ("ms", "ms"),
                                       ("body_mb", "body MB"), ("sent_mb", "sent MB"),
                                       ("peak_rss_mib", "peak RSS MiB"), ("message", "message")]))
    if "files" in report:
        print("\n## files: the real CLI as a subprocess (peak RSS = the child's ru_maxrss)\n")
        print(table(report["files"], [("case", "case"), ("exit", "exit"), ("wall_s", "wall s"),
                                      ("peak_rss_mib", "peak RSS MiB"), ("message", "first line of stderr")]))
    if "batch" in report:
        b = report["batch"]
        print(f"\n## batch: a solution printing {size_name(report['shout_mib'])} to stdout\n")
        print(table([b], [("case", "case"), ("exit", "exit"), ("wall_s", "wall s"), ("peak_rss_mib", "peak RSS MiB"),
                          ("log_mib", "log MiB"), ("log_last_line", "last line of the log")]))
        print(f"\nthe batch's episode line: {b['outcome']}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="server,files,batch", help="comma list of groups: server, files, batch")
    ap.add_argument("--env", default="miniroom:1", help="the backend's environment (server group)")
    ap.add_argument("--batch-env", default="miniroom:4", help="the batch episode's environment")
    ap.add_argument("--camera-size", default="64x48")
    ap.add_argument("--arch", default="cpu")
    ap.add_argument("--startup-timeout", type=float, default=180.0, help="seconds for benchbot run to be ready")
    ap.add_argument("--request-timeout", type=float, default=60.0, help="seconds per request (server group)")
    ap.add_argument("--cli-timeout", type=float, default=120.0, help="seconds per command (files group)")
    ap.add_argument("--batch-timeout", type=float, default=600.0, help="seconds for the batch")
    ap.add_argument("--shout-mib", type=int, default=1024, help="MiB the batch group's solution prints")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, shout_mib=32)
    if args.shout_mib < 1:
        ap.error("--shout-mib must be at least 1")
    groups = {g.strip() for g in args.only.split(",") if g.strip()}
    if not groups or groups - {"server", "files", "batch"}:
        ap.error("--only takes a comma list of server, files, batch")
    report: dict = {"machine": f"{platform.machine()} {os.cpu_count()} cpu, {platform.python_implementation()} "
                               f"{platform.python_version()}",
                    "env": args.env, "camera_size": args.camera_size, "arch": args.arch, "shout_mib": args.shout_mib}
    with tempfile.TemporaryDirectory(prefix="benchbot-hostile-") as name:
        tmp = Path(name)
        if "server" in groups:
            report["server"] = server_cases(args, tmp)
        if "files" in groups:
            report["files"] = file_cases(args, tmp)
        if "batch" in groups:
            report["batch"] = batch_case(args, tmp)
    print_report(report, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
