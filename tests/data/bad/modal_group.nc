(expect error 21 line 4: two words of one modal group)
G21 G90
G1 X0 Y0 F200
G0 G1 X5
X10
G0 Z5
