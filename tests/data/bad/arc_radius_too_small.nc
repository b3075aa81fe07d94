(expect error 34 line 4: R arc too small to reach its end)
G21 G90
G1 X0 Y0 F300
G2 X20 Y0 R5
G1 X1
