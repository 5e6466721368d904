"""``ocp-constraints bench``: run time against error, peers side by side, scaling and stress
(uses everything below it; nothing imports it but the CLI)."""
