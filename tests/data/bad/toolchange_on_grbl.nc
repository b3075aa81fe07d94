(expect error 20 line 3 dialect grbl: tool change on GRBL)
G21
T2M6
G0X1
