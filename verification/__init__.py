"""Material-removal verification: what the emitted G-code will actually cut.

Will own: replaying a parsed program through the machine's forward kinematics (with the
joints interpolated between blocks as the controller does), sweeping the cutter through a
stock model (a height map for 3-axis, point-sampled distances for 5-axis), and comparing the
cut surface with the design surface: gouges, remaining scallops, uncut areas, each traced
to its block and source line.
"""
