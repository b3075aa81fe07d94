(expect error 20 line 3: unsupported G code)
G21
G28 X0
G0 X1
