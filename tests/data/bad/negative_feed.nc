(expect error 4 line 3: negative feed)
G21
G1 X1 F-100
G1 X2 F100
