(expect error 11 line 3 dialect grbl: 80 characters, over the 79-character GRBL limit)
G21G90
N1234G1X1234567.123456789Y2345678.234567891Z-3456789.345678912F1000.123456789012 (comments do not count)
G0X1
