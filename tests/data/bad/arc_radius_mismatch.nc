(expect error 100 line 4: arc start and end radii disagree)
G21 G90 G17
G1 X10 Y0 F300
G2 X0 Y-8 I-10 J0
G1 X0 Y0
