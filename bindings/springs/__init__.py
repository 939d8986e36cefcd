"""Generalised springs, virtual-joint models of serial and parallel robots, stiffness indices."""
