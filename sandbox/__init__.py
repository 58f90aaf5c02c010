"""Garment simulation sandbox on Taichi.

Implements Leong, Kuo and Fang (2011), "A Clothing Simulation System for Realistic
Clothing and Mannequin": an anisotropic triangle model (Eq. 6-8), symplectic Euler
(Eq. 2) and the paper's stop rule, driven from scene files.

Data flows one way: pattern / mannequin (numpy) -> builder -> Taichi Model and State ->
Solver.step -> writer or viewer. SI units inside (m, kg, s), Y up.
"""

from sandbox.errors import SandboxError

__all__ = ["SandboxError"]
__version__ = "0.1.0"
