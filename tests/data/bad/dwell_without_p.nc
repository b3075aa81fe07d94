(expect error 28 line 3: G4 without P)
G21
G4
G0 X1
