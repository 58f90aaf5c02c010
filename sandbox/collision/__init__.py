"""Contact: cloth against rigid bodies (``body``), collider shapes (``shapes``) and the
solver-independent contact measures written to metrics.json (``metrics``)."""
