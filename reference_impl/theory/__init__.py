"""The paper's theory: the harmonic map, the action, the universal damping law."""
