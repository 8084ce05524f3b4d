"""The first process of a containerised solution: it runs INSIDE the container, with the image's own ``python3``
and the standard library only (no BenchBot), next to :mod:`benchbot.solutions.socket_relay` in a read-only folder
that :mod:`benchbot.solutions.containers` binds in.

``python3 -I -S container_init.py --outputs DIR --original-result FILE --home DIR RELAY-OPTIONS -- COMMAND...``:

1. makes itself non-dumpable (``prctl(PR_SET_DUMPABLE, 0)``), so that the solution, a process of the same user,
   cannot open this process's files through ``/proc/1/fd`` (its standard output is the host's channel, below);
2. makes ``HOME`` and the link ``FILE`` → ``DIR/benchbot_result`` (the original client writes ``/tmp/benchbot_result``;
   ``/tmp`` is a fresh tmpfs);
3. moves its own standard output aside and points descriptor 1 at standard error, so the solution's output (both
   streams) goes to the container's standard error, which the host logs;
4. runs :func:`socket_relay.main` with ``RELAY-OPTIONS -- COMMAND`` (``127.0.0.1:PORT`` inside relayed to the
   backend's Unix socket; the command started once the ports listen);
5. when the command has ended, writes one uncompressed tar stream to the standard output it kept: ``report.json``
   (``{"status": exit status of the command, 128 + n for a signal n, "oom_kills": memory cgroup OOM kills,
   "pids_refused": forks the pids cgroup refused, "full": the writable folders (``/tmp``, ``DIR``) left with less
   than 64 KiB}``, counters ``null`` where the cgroup file cannot be read), then every entry of ``DIR`` under
   ``outputs/`` (symbolic links as links: the host drops them);
6. exits with the command's status.

The counters come from the container's own cgroup files (cgroup v2: ``memory.events``, ``pids.events``; v1:
``memory/memory.oom_control``, ``pids/pids.events``), which the engine shows read-only inside: the host cannot read
them after the container is gone. A solution could forge nothing here that would help it: it cannot reach this
process's standard output, and a forged report could only turn its own failed episode into ``resource_limit``.

Written for any Python 3.6 or later (what an original-style image may have).
"""

import json
import os
import sys
import tarfile
import io

#: Cgroup files (v2, then v1) and the key whose count is read from each.
OOM_FILES = (("/sys/fs/cgroup/memory.events", "oom_kill"), ("/sys/fs/cgroup/memory/memory.oom_control", "oom_kill"))
PIDS_FILES = (("/sys/fs/cgroup/pids.events", "max"), ("/sys/fs/cgroup/pids/pids.events", "max"))


def counter(files):
    """The count after the key in the first readable file of ``files`` (``key N`` lines), None when none is."""
    for path, key in files:
        try:
            with open(path) as f:
                for line in f:
                    words = line.split()
                    if len(words) == 2 and words[0] == key:
                        return int(words[1])
        except (OSError, ValueError):
            continue
    return None


def full(folders, margin=64 << 10):
    """The folders of ``folders`` whose file system has less than ``margin`` bytes free (a tmpfs written full)."""
    found = []
    for folder in folders:
        try:
            stat = os.statvfs(folder)
        except OSError:
            continue
        if stat.f_bavail * stat.f_frsize < margin:
            found.append(folder)
    return found


def not_dumpable():
    """``prctl(PR_SET_DUMPABLE, 0)`` through libc; False where it cannot be done (no ctypes, no libc)."""
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl(4, 0, 0, 0, 0) == 0  # PR_SET_DUMPABLE = 4
    except Exception:  # noqa: BLE001 - a minimal image without ctypes: the solution is then only as safe as its user
        return False


def write_report(channel, status, outputs):
    """The tar stream of step 5 on the file descriptor ``channel``; a write error (the file size limit, a closed
    pipe) is said on standard error and ends the stream."""
    report = json.dumps({"status": status, "oom_kills": counter(OOM_FILES), "pids_refused": counter(PIDS_FILES),
                         "full": full(["/tmp", outputs])})
    with os.fdopen(channel, "wb") as stream:
        try:
            with tarfile.open(fileobj=stream, mode="w|", format=tarfile.PAX_FORMAT) as tar:
                data = report.encode()
                info = tarfile.TarInfo("report.json")
                info.size = len(data)
                tar.addfile(info, io.BytesIO(data))
                if os.path.isdir(outputs):
                    for name in sorted(os.listdir(outputs)):
                        tar.add(os.path.join(outputs, name), arcname="outputs/" + name, recursive=True)
        except OSError as exc:
            sys.stderr.write("benchbot container: the outputs could not all be handed back: %s\n" % exc)


def main(argv):
    """Steps 1-6 of the module docstring; returns the exit status. 125 with a line on stderr for bad arguments."""
    own = {"--outputs": None, "--original-result": None, "--home": None}
    rest = []
    words = iter(argv)
    for word in words:
        if word in own and "--" not in rest:
            own[word] = next(words, None)
        else:
            rest.append(word)
    if None in own.values():
        sys.stderr.write("benchbot container: usage: container_init.py --outputs DIR --original-result FILE "
                         "--home DIR RELAY-OPTIONS -- COMMAND...\n")
        return 125
    if not not_dumpable():
        sys.stderr.write("benchbot container: could not make the first process non-dumpable\n")
    outputs = own["--outputs"]
    for step in (lambda: os.makedirs(own["--home"], exist_ok=True),
                 lambda: os.symlink(os.path.join(outputs, "benchbot_result"), own["--original-result"])):
        try:
            step()
        except OSError as exc:
            sys.stderr.write("benchbot container: %s\n" % exc)
    channel = os.dup(1)  # not inherited by the command (Python's descriptors are not inheritable)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import socket_relay  # noqa: E402 - beside this file, in the folder the host binds in

    status = socket_relay.main(rest)
    write_report(channel, status, outputs)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
