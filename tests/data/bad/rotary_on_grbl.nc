(expect error 20 line 3 dialect grbl: A axis on GRBL)
G21G90
G0X1A10
G0X2
