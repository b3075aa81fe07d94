(expect error 22 line 5: G93 move without F)
G21 G90
G1 X0 F500
G93
G1 X10 A15
G1 X20 A30 F60
