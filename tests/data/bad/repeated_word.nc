(expect error 25 line 3: repeated word)
G21 G90 G0 X0
G1 X1 Y2 X3 F100
X5 F100
