"""Results on disk: files written whole (summary.json, CSV) and plots. Used by every task that writes."""
