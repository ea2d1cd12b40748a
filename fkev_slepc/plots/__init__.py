"""Stage 6 — matplotlib figures drawn from archived results (never recomputing physics)."""
