(expect error 22 line 6: G93 to G94 leaves the feed undefined)
G21 G90
G93
G1 X1 F10
G94
G1 X2
