(expect error 1 line 3: expected a command letter)
G21
G1 X1 F100 #5
X2
