(expect error 101 line 3: unclosed comment)
G21
G0 X1 (open comment
X2
