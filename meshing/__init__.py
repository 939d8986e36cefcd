"""Meshing of link CAD with Gmsh and TetGen."""
