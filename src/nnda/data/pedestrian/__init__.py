"""Walking individuals after Frencl (2014): heading profiles, terrain maps, the walker simulator.

Modules: ``profiles`` (the drop / leaf / balloon heading-deviation laws),
``terrain`` (map files and their grid), ``walkers`` (the simulator and its
scenes, ending in an nnda `Dataset`). Nothing is imported here.
"""
