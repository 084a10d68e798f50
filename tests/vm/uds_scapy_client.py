#!/usr/bin/python3
"""An independent UDS client for calibd's VM test (tests/vm/agent_diag_vmtest.cpp).

Debian's python3-scapy builds the requests with its UDS layer (ISO 14229-1) and carries them
over its own user-space ISO-TP (ISOTPSoftSocket on a raw CAN socket, ISO 15765-2), or over the
kernel's can-isotp with --native: our ISO-TP use and our byte layouts are checked by code we did
not write. Run by /usr/bin/python3 (Debian's scapy is installed for it, not for pyenv's).

  uds_scapy_client.py --interface vcan0 --expect-version V --expect-serial S [--native]

Checks, in order (each printed as "ok ..." or "FAIL ..."):
  1. 10 03 -> 50 03 00 32 01 F4 (extended session, P2 50 ms, P2* 5000 ms in 10 ms units)
  2. 22 F195 -> 62 F1 95 + 16 bytes: the software version padded with spaces (a multi-frame
     response: first frame, flow control from us, consecutive frames)
  3. 22 F195 F18C FD00 FD05 (a 9-byte multi-frame request) -> the four records in the order
     asked, each of its documented size (16, 16, 24, 2 bytes)
  4. 22 12 34 -> 7F 22 31 (requestOutOfRange)
  5. 10 01 -> 50 01 00 32 01 F4 (back to the default session)
Prints "FD00 <hex>" (the current extrinsic's 24 bytes) for the caller to compare with
calibd-tester's. Exit code 0 when every check passed, 1 otherwise, 2 when no answer came.
"""

import argparse
import sys

from scapy.config import conf

# Both transports from scapy itself: no python-can, and the ISO-TP socket chosen explicitly below.
conf.contribs["CANSocket"] = {"use-python-can": False}
conf.contribs["ISOTP"] = {"use-can-isotp-kernel-module": False}

from scapy.contrib.automotive.uds import UDS, UDS_DSC, UDS_RDBI  # noqa: E402
from scapy.contrib.cansocket_native import NativeCANSocket  # noqa: E402
from scapy.contrib.isotp.isotp_native_socket import ISOTPNativeSocket  # noqa: E402
from scapy.contrib.isotp.isotp_soft_socket import ISOTPSoftSocket  # noqa: E402

PHYSICAL_REQUEST_ID = 0x7E0
PHYSICAL_RESPONSE_ID = 0x7E8
SESSION_TIMING = bytes([0x00, 0x32, 0x01, 0xF4])  # P2 50 ms, P2* 500 x 10 ms
DID_SIZES = {0xF195: 16, 0xF18C: 16, 0xFD00: 24, 0xFD05: 2}


class Checker:
    def __init__(self, sock, timeout_s):
        self.sock = sock
        self.timeout_s = timeout_s
        self.failures = 0

    def request(self, pkt):
        """Sends `pkt` (a UDS packet) and returns the response bytes; exits 2 on no answer."""
        answer = self.sock.sr1(pkt, timeout=self.timeout_s, verbose=False)
        if answer is None:
            print("FAIL no response to %s within %.1f s" % (bytes(pkt).hex(" "), self.timeout_s))
            sys.exit(2)
        return bytes(answer)

    def check(self, ok, what, got):
        print("%s %s: %s" % ("ok" if ok else "FAIL", what, got.hex(" ").upper()))
        if not ok:
            self.failures += 1


def padded(text, size):
    return text.encode("ascii").ljust(size, b" ")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--interface", default="vcan0")
    parser.add_argument("--expect-version", required=True, help="DID F195 before padding")
    parser.add_argument("--expect-serial", required=True, help="DID F18C before padding")
    parser.add_argument("--native", action="store_true", help="the kernel's can-isotp instead")
    parser.add_argument("--timeout", type=float, default=5.0, help="per request, s")
    args = parser.parse_args()

    if args.native:
        sock = ISOTPNativeSocket(args.interface, tx_id=PHYSICAL_REQUEST_ID,
                                 rx_id=PHYSICAL_RESPONSE_ID, padding=True, basecls=UDS)
    else:
        sock = ISOTPSoftSocket(NativeCANSocket(channel=args.interface),
                               tx_id=PHYSICAL_REQUEST_ID, rx_id=PHYSICAL_RESPONSE_ID,
                               padding=True, basecls=UDS)
    c = Checker(sock, args.timeout)
    try:
        # 1. ISO 14229-1 §9.2 DiagnosticSessionControl, extended.
        r = c.request(UDS() / UDS_DSC(diagnosticSessionType=0x03))
        c.check(r == bytes([0x50, 0x03]) + SESSION_TIMING, "10 03 extended session", r)

        # 2. §10.2 ReadDataByIdentifier of one DID: a 19-byte, multi-frame response.
        r = c.request(UDS() / UDS_RDBI(identifiers=[0xF195]))
        want = bytes([0x62, 0xF1, 0x95]) + padded(args.expect_version, 16)
        c.check(r == want, "22 F195 software version '%s'" % args.expect_version, r)

        # 3. Four DIDs in one 9-byte request: multi-frame in both directions.
        dids = [0xF195, 0xF18C, 0xFD00, 0xFD05]
        r = c.request(UDS() / UDS_RDBI(identifiers=dids))
        ok = len(r) > 0 and r[0] == 0x62
        pos, records = 1, {}
        for did in dids:
            size = DID_SIZES[did]
            if pos + 2 + size > len(r) or int.from_bytes(r[pos:pos + 2], "big") != did:
                ok = False
                break
            records[did] = r[pos + 2:pos + 2 + size]
            pos += 2 + size
        ok = ok and pos == len(r)
        ok = ok and records.get(0xF195) == padded(args.expect_version, 16)
        ok = ok and records.get(0xF18C) == padded(args.expect_serial, 16)
        c.check(ok, "22 F195 F18C FD00 FD05 (%d-byte response)" % len(r), r)
        if 0xFD00 in records:
            print("FD00 " + records[0xFD00].hex(" ").upper())

        # 4. An unsupported DID: negative response requestOutOfRange.
        r = c.request(UDS() / UDS_RDBI(identifiers=[0x1234]))
        c.check(r == bytes([0x7F, 0x22, 0x31]), "22 1234 -> 7F 22 31", r)

        # 5. Back to the default session.
        r = c.request(UDS() / UDS_DSC(diagnosticSessionType=0x01))
        c.check(r == bytes([0x50, 0x01]) + SESSION_TIMING, "10 01 default session", r)
    finally:
        sock.close()
    print("%d check(s) failed" % c.failures if c.failures else "all checks passed")
    return 1 if c.failures else 0


if __name__ == "__main__":
    sys.exit(main())
