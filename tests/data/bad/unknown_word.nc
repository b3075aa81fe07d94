(expect error 20 line 4: unknown word Q)
G21 G90
G0 X0 Y0
G1 X5 Q3 F100
X10
