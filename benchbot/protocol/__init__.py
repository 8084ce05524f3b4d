"""The native protocol, shared by the client (:mod:`benchbot.api`) and the backend server (:mod:`benchbot.server`):
its payload encoding (:mod:`~benchbot.protocol.wire`) and the same-host fast path of step arrays
(:mod:`~benchbot.protocol.shared_frames`). Importing it never imports the server (docs/protocol.md)."""
