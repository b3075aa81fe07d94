(expect error 2 line 3: a letter with no number)
G21
G1 X Y10 F100
G1 Y1 F100
