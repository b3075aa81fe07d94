(expect error 36 line 4: I and J without an arc)
G21 G90
G1 X0 Y0 F100
G1 X5 I2 J1
G1 X6
