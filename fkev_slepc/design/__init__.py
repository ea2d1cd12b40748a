"""Stage "design": questions a designer asks of computed results -- margins of the modes against
the crank orders over the whole cycle (``margins``), design sweeps over scene keys."""
