"""Running a solution: a native command, an installed example or a container, started against a backend, sandboxed
(bubblewrap) within documented limits, its processes stopped with its episode, its results file found and checked.

Solutions are untrusted: nothing in this package lets one read ground truth, reach anything but its backend, or
exhaust the machine (docs/security.md)."""
