"""Decodes CAN frames with a DBC file through python3-canmatrix (Debian's), a decoder we did not
write: each input line is `ID#HEXBYTES` (candump's compact form, id in hex); each output line is a
JSON object of the frame's signals (raw values), in the input's order.

Usage: /usr/bin/python3 dbc_decode.py FILE.dbc FRAMES.txt
"""
import json
import sys

import canmatrix
import canmatrix.formats


def main():
    dbc, frames = sys.argv[1], sys.argv[2]
    matrix = canmatrix.formats.loadp_flat(dbc)
    with open(frames) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            can_id, data = line.split("#")
            frame = matrix.frame_by_id(canmatrix.ArbitrationId(int(can_id, 16)))
            if frame is None:
                print(json.dumps({"error": "no frame " + can_id + " in " + dbc}))
                continue
            decoded = frame.decode(bytearray.fromhex(data))
            print(json.dumps({name: int(sig.raw_value) for name, sig in decoded.items()}))


if __name__ == "__main__":
    main()
