(expect error 2 line 4: 1e-3 style number)
G21 G90
G1 X0 F100
G1 X1e-3
X2
