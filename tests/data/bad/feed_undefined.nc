(expect error 22 line 4: feed move with no feed defined)
G21 G90
G0 X0 Y0 Z5
G1 Z-1
F200
G1 Z-1
