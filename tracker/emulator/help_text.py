"""Help screens (H, H2, H3) as the GS-232B and the GS-23/GS-232 manuals print them.

The GS-232B text is the manual's OCR cleaned up by hand (spelling fixed, layout kept); the
Kenpro V1.2 text is verbatim from its manual.
"""

from __future__ import annotations

GS232B_H = """---------- COMMAND LIST 1 ----------
R  Clockwise Rotation
L  Counter Clockwise Rotation
A  CW/CCW Rotation Stop
C  Antenna Direction Value
M  Antenna Direction Setting. MXXX
M  Time Interval Direction Setting.
   MTTT XXX XXX XXX ---
   (TTT = Step value)
   (XXX = Horizontal Angle)
T  Start Command in the time interval direction setting mode.
N  Total number of setting angles in "M" mode and
   traced number of all datas (setting angles)
S  All Stop
O  Offset Calibration
F  Full Scale Calibration
X1 Rotation Speed 1 (Horizontal) Low
X2 Rotation Speed 2 (Horizontal) Middle 1
X3 Rotation Speed 3 (Horizontal) Middle 2
X4 Rotation Speed 4 (Horizontal) High"""

GS232B_H2 = """---------- HELP COMMAND 2 ----------
U  UP Direction Rotation
D  DOWN Direction Rotation
E  UP/DOWN Direction Rotation Stop
C2 Antenna Direction Value
W  Antenna Direction Setting.
   WXXX YYY
W  Time Interval Direction Setting.
   WTTT XXX YYY XXX YYY ---
   (TTT = Step value)
   (XXX = Horizontal Angle)
   (YYY = Elevation Angle)
T  Start Command in the time interval direction setting mode.
N  Total number of setting angle in "W" mode and
   traced number of all datas (setting angles)
S  All Stop
O2 Offset Calibration
F2 Full Scale Calibration
B  Elevation Antenna Direction Value"""

GS232B_H3 = """---------- HELP COMMAND 3 ----------
P45 Set_mode 450 Degree
P36 Set_mode 360 Degree
Z   Switch N Center/S Center
-------------------- MODE --------------------
{mode}
{centre}"""

KENPRO_H = """-----COMMAND LIST 1-----
R Clockwise Rotation
L Counter Clockwise Rotation
A CW/CCW Rotation Stop
C Antenna Direction Value
M Antenna Direction Setting. MXXX
M Time interval Direction
Setting. MTTT XXX XXX XXX ---
(TTT=Step value)
(XXX=Horizontal Angle)
T Start Comand in the time interval
Ddirection setting mode.
N Total number of setting angle in
'M' mode and traced number of all
datas(setting angles)
X1 Rotation Speed 1(Horizontal)Low
X2 Rotation Speed 2(Horizontal)Middle 1
X3 Rotation Speed 3(Horizontal)Middle 2
X4 Rotation Speed 4(Horizontal)High
S All Stop
O Offset Calibration
F Full Scale Calibration
(after calibration push reset switch)
(V1.2) Copyright 1988.6 by KENPRO"""

KENPRO_H2 = """-----HELP COMMAND 2-----
U UP Direction Rotation
D DOUN Direction Rotation
E UP/DOWN Direction Rotation Stop
C2 Antenna Direction Value
W Antenna Direction Setting.
WXXX YYY
W Time Interval Direction
Seting. WTTT XXX YYY XXX YYY ---
(TTT=Step value)
(XXX=Horizontal Angle)
(YYY=Elevation Angle)
T Start Command in the time interval
direction setting mode.
N Total number of setting angle in
'W' mode and traced number of all
datas(setting angles)
S All Stop
O2 Offset Calibration
F2 Full Scale Calibration
B Elevation Antenna Direction Value
(V1.2) Copyright 1988.6 by KENPRO"""


def help_screen(family: str, page: str, mode_450: bool = True, south: bool = False) -> bytes:
    """The bytes of help page ``page`` ("", "2", "3"), lines ended by CR LF."""
    if family == "a":
        text = {"": KENPRO_H, "2": KENPRO_H2}[page]
    else:
        text = {"": GS232B_H, "2": GS232B_H2, "3": GS232B_H3}[page].format(
            mode="mode 450 Degree" if mode_450 else "mode 360 Degree",
            centre="S Center" if south else "N Center")
    return text.replace("\n", "\r\n").encode("ascii") + b"\r\n"
