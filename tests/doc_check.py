#!/usr/bin/python3
"""Doc check: the guides in docs/ cannot rot.

1. Runs every command of the guides' ```sh blocks, in order, in a temporary directory, with the
   built executables first on PATH. System paths the commands name (/etc/calibd, /var/lib/calibd,
   /tmp/calibd-desk) are moved under the temporary directory, so nothing outside it is written;
   `cd DIR` carries over to the next commands of the same guide. A command passes when it exits
   with 0, or with N when its trailing comment says "exit code N" ("exit code N: MESSAGE": and
   MESSAGE is in its output). Commands that need what a build machine lacks are checked as far
   as it goes:
   - calibd-tester: run with the guide's exact arguments against a CAN interface that does not
     exist; it must exit with 7 ("CAN interface missing"), which proves the command line parses
     (a bad one exits with 2). `calibd-tester --help` must exit with 0, and every exit code it
     lists must have a row in the operator guide's exit code table.
   - systemctl / journalctl / systemd-analyze: the unit they name must be deploy/systemd's, the
     verb one systemctl knows; the unit (its template with the built agent's path) must pass
     `systemd-analyze verify` when that exists, else it is parsed for its sections and ExecStart.
   - systemd-sysusers: deploy/systemd/calibd.sysusers in a dry run (when it exists).
   - chown USER[:GROUP] FILE: the user and group must be created by calibd.sysusers and FILE
     must exist (the command itself is not run: the build machine has no such user).
   - candump IFACE,ID:MASK: the id must be the status frame's in deploy/calibd.dbc.
   - a command reading a recorded `--folder DIR` that does not exist here: it must exit with 1
     naming DIR (its options, config and intrinsics were accepted; a bad one exits with 2).
2. Checks that the operator guide's troubleshooting tables (docs/troubleshooting.md) name every
   reason code and DTC the sources define (read from the headers, so a new code without
   documentation fails), and that the integration guide with its references (GUIDE_REFERENCES)
   names every LCM channel, type and field, DID, routine, DBC signal, LiDAR model and config key
   (deploy/config/calibd.yaml's and every key the config loader accepts).
3. Checks every relative link and image of README.md and docs/*.md: the file exists, and a
   #anchor names a heading of the document it points to.

A failure prints the guide, the line and the command. Usage:
  doc_check.py --source DIR --bin-dir DIR [--bin-dir DIR ...] [--tmp DIR] [--only FILE]
"""

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

GUIDES = ["docs/operator-guide.md", "docs/integration-guide.md"]
# The reference documents split out of each guide: the coverage checks (2.) read them with it.
GUIDE_REFERENCES = {
    "docs/operator-guide.md": ["docs/troubleshooting.md"],
    "docs/integration-guide.md": ["docs/lcm-interface.md", "docs/configuration.md",
                                  "docs/can-diagnostics.md"],
}
# Paths the guides may name that must not be touched on the build machine: moved under the
# temporary directory.
MOVED_PREFIXES = ["/etc/calibd", "/var/lib/calibd", "/tmp/calibd-desk"]
TESTER_EXIT_INTERFACE = 7
MISSING_INTERFACE = "calibdnocan0"  # 12 characters: a valid, absent interface name
COMMAND_TIMEOUT_S = 120
SYSTEMCTL_VERBS = {
    "start", "stop", "restart", "reload", "status", "enable", "disable", "is-active",
    "is-enabled", "is-failed", "show", "cat", "daemon-reload", "reset-failed", "kill",
    "list-units", "mask", "unmask", "edit",
}


class Failure(Exception):
    pass


# --- extraction -------------------------------------------------------------------------------


def extract_commands(path):
    """The commands of a guide's ```sh blocks: (line, text) with continuation lines joined and
    here-documents kept whole. A comment line or a trailing comment is kept in the text (bash
    ignores it; the exit-code convention reads it)."""
    commands = []
    in_block = False
    pending = None  # (line, text) of a command continued with a trailing backslash
    heredoc_end = None
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    for number, raw in enumerate(lines, start=1):
        stripped = raw.strip()
        if not in_block:
            if stripped == "```sh":
                in_block = True
            continue
        if heredoc_end is not None:
            line0, text = commands[-1]
            commands[-1] = (line0, text + "\n" + raw)
            if stripped == heredoc_end:
                heredoc_end = None
            continue
        if stripped == "```":
            if pending:
                raise Failure(f"{path}:{pending[0]}: a command ends with a backslash")
            in_block = False
            continue
        if pending is None and (not stripped or stripped.startswith("#")):
            continue
        if pending is not None:
            text = pending[1] + "\n" + raw
            line0 = pending[0]
        else:
            text, line0 = raw, number
        if raw.endswith("\\"):
            pending = (line0, text)
            continue
        pending = None
        commands.append((line0, text))
        m = re.search(r"<<-?\s*'?\"?([A-Za-z_]+)'?\"?", strip_comment(text))
        if m:
            heredoc_end = m.group(1)
    if in_block:
        raise Failure(f"{path}: a ```sh block is not closed")
    return commands


def strip_comment(text):
    """The command without its trailing comment (a # outside quotes after whitespace)."""
    out, quote = [], None
    for i, ch in enumerate(text):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or text[i - 1] in " \t\n"):
            # the comment runs to the end of its line; a continued command goes on after it
            rest = text[i:]
            nl = rest.find("\n")
            if nl < 0:
                break
            out.append(strip_comment(rest[nl:]))
            return "".join(out)
        out.append(ch)
    return "".join(out)


def expected_exit(text):
    """(exit code, message) a command's trailing comment promises: "# exit code N: MESSAGE" (the
    message, when given, must appear in the command's output); (0, "") without such a comment."""
    m = re.search(r"#.*\bexit code (\d+)(?::\s*(.*))?$", text.split("\n")[0])
    if not m:
        return 0, ""
    return int(m.group(1)), (m.group(2) or "").strip()


# --- the command handlers ------------------------------------------------------------------------


class Runner:
    def __init__(self, source, bin_dirs, tmp_root):
        self.source = source
        self.tmp_root = tmp_root
        self.env = dict(os.environ)
        self.env["PATH"] = os.pathsep.join(bin_dirs + [self.env.get("PATH", "/usr/bin:/bin")])
        self.env["LC_ALL"] = "C"
        self.bin_dirs = bin_dirs
        self.unit_verified = False
        self.sysusers = parse_sysusers(os.path.join(source, "deploy/systemd/calibd.sysusers"))

    def moved(self, text):
        for prefix in MOVED_PREFIXES:
            text = text.replace(prefix, self.tmp_root + prefix)
        return text

    def run_shell(self, text, cwd, timeout=COMMAND_TIMEOUT_S):
        return subprocess.run(["bash", "-o", "pipefail", "-c", text], cwd=cwd, env=self.env,
                              stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, timeout=timeout, text=True,
                              errors="replace")

    def check(self, text, cwd):
        """Runs or checks one command; returns the next working directory."""
        command = strip_comment(text).strip()
        try:
            words = shlex.split(command)
        except ValueError:
            words = []
        program = words[0] if words else ""
        if program == "cd" and len(words) == 2:
            target = os.path.join(cwd, self.moved(words[1]))
            if not os.path.isdir(target):
                raise Failure(f"cd: {target} does not exist")
            return target
        if program == "calibd-tester":
            self.check_tester(words, cwd)
        elif program in ("systemctl", "journalctl", "systemd-analyze"):
            self.check_systemd(program, words)
        elif program == "systemd-sysusers":
            self.check_sysusers()
        elif program == "chown":
            self.check_chown(words, cwd)
        elif program == "candump":
            self.check_candump(words)
        elif "--folder" in words and not os.path.exists(
                os.path.join(cwd, self.moved(value_of(words, "--folder")))):
            self.check_missing_folder(text, words, cwd)
        else:
            want, message = expected_exit(text)
            result = self.run_shell(self.moved(text), cwd)
            if result.returncode != want:
                raise Failure(f"exit code {result.returncode}, expected {want}; output:\n"
                              + tail(result.stdout))
            if message and message not in result.stdout:
                raise Failure(f"the output lacks the documented '{message}':\n"
                              + tail(result.stdout))
        return cwd

    def check_missing_folder(self, text, words, cwd):
        """A recorded folder the build machine does not have: the command must get as far as
        reading it (options, config and intrinsics accepted) and fail naming it (exit code 1)."""
        folder = value_of(words, "--folder")
        result = self.run_shell(self.moved(text), cwd)
        if result.returncode != 1 or folder.rstrip("/") not in result.stdout:
            raise Failure(f"with the folder {folder} missing: exit code {result.returncode} "
                          f"(expected 1, naming the folder); output:\n" + tail(result.stdout))

    def check_tester(self, words, cwd):
        args = list(words[1:])
        if "--help" in args:
            result = subprocess.run(["calibd-tester"] + args, cwd=cwd, env=self.env,
                                    capture_output=True, text=True, timeout=10)
            if result.returncode != 0 or "Usage: calibd-tester" not in result.stdout:
                raise Failure(f"calibd-tester --help exited {result.returncode}")
            # Every exit code the tester documents has a row in the operator guide's table.
            codes = re.findall(r"(?<![\w.])(\d+) (?=[A-Za-z])",
                               result.stdout.split("Exit codes:")[1])
            rows = table_rows(read(self.source, GUIDES[0]))
            for code in codes:
                if not re.search(rf"^\| {code} \|", rows, re.M):
                    raise Failure(f"calibd-tester's exit code {code} has no row in the operator "
                                  "guide's exit code table")
            return
        if "--interface" in args:
            i = args.index("--interface")
            if i + 1 >= len(args):
                raise Failure("--interface without a value")
            args[i + 1] = MISSING_INTERFACE
        else:
            args = ["--interface", MISSING_INTERFACE] + args
        result = subprocess.run(["calibd-tester"] + [self.moved(a) for a in args], cwd=cwd,
                                env=self.env, capture_output=True, text=True, timeout=30)
        if result.returncode != TESTER_EXIT_INTERFACE or MISSING_INTERFACE not in result.stderr:
            raise Failure(f"calibd-tester against a missing interface exited "
                          f"{result.returncode} (expected {TESTER_EXIT_INTERFACE}: the command "
                          f"line must parse): {result.stderr.strip()}")

    def verify_unit(self):
        if self.unit_verified:
            return
        template = os.path.join(self.source, "deploy/systemd/calibd.service.in")
        with open(template, encoding="utf-8") as f:
            unit = f.read()
        agent = shutil.which("calibd-agent", path=self.env["PATH"])
        if agent is None:
            raise Failure("calibd-agent is not on PATH")
        unit = unit.replace("@CMAKE_INSTALL_FULL_BINDIR@", os.path.dirname(agent))
        unit = unit.replace("@CMAKE_INSTALL_FULL_SYSCONFDIR@", self.tmp_root + "/etc")
        if re.search(r"@[A-Z_]+@", unit):
            raise Failure("calibd.service.in: an @VARIABLE@ is left after substitution")
        unit_dir = os.path.join(self.tmp_root, "units")
        os.makedirs(unit_dir, exist_ok=True)
        path = os.path.join(unit_dir, "calibd.service")
        with open(path, "w", encoding="utf-8") as f:
            f.write(unit)
        analyze = shutil.which("systemd-analyze")
        if analyze:
            result = subprocess.run([analyze, "verify", path], capture_output=True, text=True,
                                    timeout=60)
            out = (result.stdout + result.stderr).strip()
            if result.returncode != 0 or out:
                raise Failure(f"systemd-analyze verify calibd.service: {out}")
        else:
            sections = re.findall(r"^\[(\w+)\]", unit, re.M)
            if sections != ["Unit", "Service", "Install"] or not re.search(
                    r"^ExecStart=\S*calibd-agent ", unit, re.M):
                raise Failure("calibd.service: sections or ExecStart not as expected")
        self.unit_verified = True

    def check_systemd(self, program, words):
        self.verify_unit()
        args = words[1:]
        if program == "systemctl":
            verbs = [a for a in args if not a.startswith("-")]
            if not verbs or verbs[0] not in SYSTEMCTL_VERBS:
                raise Failure(f"systemctl: unknown verb in {' '.join(args)}")
            units = verbs[1:]
            if verbs[0] == "daemon-reload":
                if units:
                    raise Failure("systemctl daemon-reload takes no unit")
                return
        elif program == "journalctl":
            if "-u" not in args or args.index("-u") + 1 >= len(args):
                raise Failure("journalctl without -u UNIT")
            units = [args[args.index("-u") + 1]]
        else:  # systemd-analyze security|verify UNIT
            if not args or args[0] not in ("security", "verify"):
                raise Failure(f"systemd-analyze: unexpected {' '.join(args)}")
            units = args[1:]
        if not units:
            raise Failure(f"{program}: no unit named")
        for unit in units:
            if unit not in ("calibd", "calibd.service"):
                raise Failure(f"{program}: unit {unit} is not deploy/systemd's calibd.service")

    def check_sysusers(self):
        tool = shutil.which("systemd-sysusers")
        path = os.path.join(self.source, "deploy/systemd/calibd.sysusers")
        if not tool:
            if "calibd" not in self.sysusers["u"]:
                raise Failure("calibd.sysusers creates no calibd user")
            return
        root = os.path.join(self.tmp_root, "sysusers-root")
        os.makedirs(os.path.join(root, "etc"), exist_ok=True)
        result = subprocess.run([tool, f"--root={root}", "--dry-run", path], capture_output=True,
                                text=True, timeout=30)
        out = result.stdout + result.stderr
        if result.returncode != 0 or "calibd" not in out:
            raise Failure(f"systemd-sysusers --dry-run calibd.sysusers: {out.strip()}")

    def check_chown(self, words, cwd):
        args = [a for a in words[1:] if not a.startswith("-")]
        if len(args) < 2:
            raise Failure("chown: owner and file expected")
        user, _, group = args[0].partition(":")
        if user not in self.sysusers["u"]:
            raise Failure(f"chown: user {user} is not created by calibd.sysusers")
        if group and group not in self.sysusers["u"] | self.sysusers["g"]:
            raise Failure(f"chown: group {group} is not created by calibd.sysusers")
        for path in args[1:]:
            if not os.path.exists(os.path.join(cwd, self.moved(path))):
                raise Failure(f"chown: {path} does not exist at this point of the guide")

    def check_candump(self, words):
        dbc = os.path.join(self.source, "deploy/calibd.dbc")
        with open(dbc, encoding="utf-8") as f:
            ids = {int(m) for m in re.findall(r"^BO_ (\d+) ", f.read(), re.M)}
        specs = [a for a in words[1:] if not a.startswith("-")]
        if not specs:
            raise Failure("candump: no interface")
        for spec in specs:
            for flt in spec.split(",")[1:]:
                m = re.fullmatch(r"([0-9A-Fa-f]+):([0-9A-Fa-f]+)", flt)
                if not m:
                    raise Failure(f"candump: filter {flt} is not ID:MASK")
                if int(m.group(1), 16) not in ids:
                    raise Failure(f"candump: id {m.group(1)} is not a frame of calibd.dbc")


def value_of(words, option):
    i = words.index(option)
    if i + 1 >= len(words):
        raise Failure(f"{option} without a value")
    return words[i + 1]


def parse_sysusers(path):
    made = {"u": set(), "g": set(), "m": set()}
    with open(path, encoding="utf-8") as f:
        for line in f:
            parts = line.split()
            if parts and parts[0] in made and len(parts) > 1:
                made[parts[0]].add(parts[1])
    return made


def tail(text, lines=25):
    return "\n".join(text.rstrip().split("\n")[-lines:])


# --- what the guides must name ---------------------------------------------------------------


def read(source, path):
    with open(os.path.join(source, path), encoding="utf-8") as f:
        return f.read()


def reasons(source):
    """(code, name) of every reason of core reason.hpp's one table, e.g. (0x0B,
    'high_reprojection_error'), but `other`."""
    header = read(source, "core/include/calibd/core/verdict/reason.hpp")
    values = dict(re.findall(r"(k\w+) = 0x([0-9A-Fa-f]+)", header))
    pairs = re.findall(r'\{Reason::(k\w+), "([a-z_]+)"\}', header)
    if not pairs:
        raise SystemExit("doc_check: no reason names found in core/include/calibd/core/verdict/reason.hpp")
    return [(int(values[k], 16), name) for k, name in pairs if name != "other"]


def dtcs(source):
    """(J2012 text, 0xNNNNNN) of every DTC, from dtc_store.hpp's list, checked against its
    kDtcNumbers array."""
    header = read(source, "agent/include/calibd/agent/uds/dtc_store.hpp")
    listed = re.findall(r"/// - ([PCBU][0-9A-F]{4}-[0-9A-F]{2}) = 0x([0-9A-F]{6})", header)
    array = header.split("kDtcNumbers = {")[1].split("}")[0]
    numbers = re.findall(r"0x([0-9A-Fa-f]{6})", array)
    if sorted(n.upper() for n in numbers) != sorted(n for _, n in listed):
        raise Failure("dtc_store.hpp: the DTC list in the comment differs from kDtcNumbers")
    return listed


def table_rows(text):
    return "\n".join(line for line in text.split("\n") if line.lstrip().startswith("|"))


def config_keys(source):
    """Dotted key paths of deploy/config/calibd.yaml (a list of maps as key[].sub), plus every
    board key the config loader knows (drivers/src/config_file.cpp), checkerboard ones included."""
    keys = []
    stack = []  # [indent, key]
    for line in read(source, "deploy/config/calibd.yaml").split("\n"):
        code = line.split("#", 1)[0].rstrip()
        m = re.match(r"^(\s*)(- )?([A-Za-z_][A-Za-z0-9_]*):", code)
        if not m:
            continue
        indent = len(m.group(1)) + (2 if m.group(2) else 0)
        while stack and stack[-1][0] >= indent:
            stack.pop()
        if m.group(2) and stack and not stack[-1][1].endswith("[]"):
            stack[-1][1] += "[]"
            keys = [k for k in keys if k != stack[-1][1][:-2]]
        path = ".".join(k for _, k in stack + [[indent, m.group(3)]])
        if path not in keys:
            keys.append(path)
        stack.append([indent, m.group(3)])
    # The calibration part's loader names every key it accepts: CheckKnown(node, {names}, "prefix")
    # (a board's prefix is a variable: boards[i]).
    loader = read(source, "drivers/src/config_file.cpp")
    for names, prefix in re.findall(r"CheckKnown\(\s*\w+,\s*\{([^}]*)\},\s*(\"[\w.]*\"|\w+)\)",
                                    loader):
        prefix = prefix.strip('"') if prefix.startswith('"') else "boards[]"
        for name in re.findall(r'"(\w+)"', names):
            key = f"{prefix}.{name}" if prefix else name
            if key not in keys:
                keys.append(key)
    return keys


def lidar_models(source):
    """The LiDAR model names the config accepts (the kLidarNames table LidarKindFromName reads)."""
    text = read(source, "core/src/lidar/lidar_model.cpp")
    body = text.split("kLidarNames[] = {")[1].split("};")[0]
    names = re.findall(r'\{"([\w-]+)", LidarKind::', body)
    if not names:
        raise SystemExit("doc_check: no LiDAR model names found in core/src/lidar/lidar_model.cpp")
    return names


def check_coverage(source, operator, integration):
    missing = []
    trouble = table_rows(operator)
    for value, name in reasons(source):
        if f"`{name}` (0x{value:02X})" not in trouble:
            missing.append(f"operator guide: reason `{name}` (0x{value:02X}) has no "
                           "troubleshooting row")
    for j2012, number in dtcs(source):
        if number not in trouble or j2012 not in trouble:
            missing.append(f"operator guide: DTC {j2012} ({number}) has no troubleshooting row")
        if number not in table_rows(integration):
            missing.append(f"integration guide: DTC {number} is not in a table")

    rows = table_rows(integration)
    channels = read(source, "lcm_types/include/calibd/channels.hpp")
    for name, typ in re.findall(r'ChannelSpec k\w+\{"(\w+)", "calibd\.(\w+)"', channels):
        if f"`{name}`" not in rows or f"`{typ}`" not in rows:
            missing.append(f"integration guide: channel {name} / {typ} not in a table")
    for lcm in sorted(os.listdir(os.path.join(source, "lcm_types"))):
        if lcm.endswith(".lcm"):
            struct = read(source, "lcm_types/" + lcm)
            for field in re.findall(r"^\s+\w+\s+(\w+)(?:\[\w+\])?;", struct, re.M):
                if f"`{field}`" not in integration:
                    missing.append(f"integration guide: field {lcm[:-4]}.{field} not named")
    dids = read(source, "agent/include/calibd/agent/uds/did_codec.hpp")
    for did in re.findall(r"kDid\w+ = 0x([0-9A-F]{4})", dids):
        if did not in rows:
            missing.append(f"integration guide: DID {did} not in a table")
        if did not in table_rows(operator) and did.startswith("FD"):
            missing.append(f"operator guide: DID {did} not in a table")
    routines = read(source, "agent/include/calibd/agent/uds/routines.hpp")
    for rid in re.findall(r"kRoutine\w+ = 0x([0-9A-F]{4})", routines):
        if rid not in rows:
            missing.append(f"integration guide: routine {rid} not in a table")
    dbc = read(source, "deploy/calibd.dbc")
    for signal in re.findall(r"^ SG_ (\w+) :", dbc, re.M):
        if f"`{signal}`" not in rows:
            missing.append(f"integration guide: DBC signal {signal} not in a table")
    for key in config_keys(source):
        if f"`{key}`" not in integration:
            missing.append(f"integration guide: config key `{key}` not named")
    for model in lidar_models(source):
        if f"`{model}`" not in rows:
            missing.append(f"integration guide: LiDAR model `{model}` not in a table")
    if "](operator-guide.md" not in integration:
        missing.append("integration guide: no link to the operator guide")
    if "](integration-guide.md" not in operator:
        missing.append("operator guide: no link to the integration guide")
    readme = read(source, "README.md")
    for guide in GUIDES:
        if f"]({guide}" not in readme:
            missing.append(f"README.md: no link to {guide}")
    return missing


# --- links -----------------------------------------------------------------------------------

LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def slug(heading):
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to '-'."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(text):
    """Every heading's anchor in a Markdown text (code blocks skipped; repeats get -1, -2...)."""
    seen, out, fenced = {}, set(), False
    for line in text.splitlines():
        if line.startswith("```"):
            fenced = not fenced
        m = None if fenced else re.match(r"#{1,6} (.*)", line)
        if m:
            base = slug(m.group(1))
            n = seen.get(base, 0)
            seen[base] = n + 1
            out.add(base if n == 0 else f"{base}-{n}")
    return out


def check_links(source):
    """Every relative link (and image) of README.md and docs/*.md names a file of the repository,
    and its #anchor a heading of the document it points to."""
    documents = ["README.md"] + sorted(
        os.path.join("docs", f) for f in os.listdir(os.path.join(source, "docs"))
        if f.endswith(".md"))
    missing = []
    for doc in documents:
        # Code blocks blanked (their lines kept for the numbers): link text may span lines.
        lines, fenced = [], False
        for line in read(source, doc).splitlines():
            if line.startswith("```"):
                fenced = not fenced
                line = ""
            lines.append("" if fenced else line)
        text = "\n".join(lines)
        for match in LINK.finditer(text):
            target = match.group(1)
            number = text.count("\n", 0, match.start()) + 1
            if re.match(r"[a-z]+:", target):
                continue  # http(s), mailto: outside the repository
            path, _, anchor = target.partition("#")
            resolved = os.path.normpath(os.path.join(os.path.dirname(doc), path)) if path else doc
            if not os.path.exists(os.path.join(source, resolved)):
                missing.append(f"{doc}:{number}: link to {target}: no file {resolved}")
            elif anchor and resolved.endswith(".md") and \
                    anchor not in anchors(read(source, resolved)):
                missing.append(f"{doc}:{number}: link to {target}: no heading #{anchor}")
    return missing


# --- main ------------------------------------------------------------------------------------


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--source", required=True)
    parser.add_argument("--bin-dir", action="append", default=[])
    parser.add_argument("--tmp", default=None)
    parser.add_argument("--only", default=None, help="run the commands of this guide only")
    parser.add_argument("--no-commands", action="store_true", help="only the coverage checks")
    a = parser.parse_args()
    source = os.path.abspath(a.source)
    bin_dirs = [os.path.abspath(d) for d in a.bin_dir]
    if a.tmp:
        a.tmp = os.path.abspath(a.tmp)
        os.makedirs(a.tmp, exist_ok=True)
    failures = []
    start = time.monotonic()
    try:
        texts = {g: "\n".join(read(source, d) for d in [g] + GUIDE_REFERENCES[g]) for g in GUIDES}
        failures += check_coverage(source, texts[GUIDES[0]], texts[GUIDES[1]])
        failures += check_links(source)
    except (Failure, OSError, IndexError) as e:
        failures.append(f"coverage check: {e}")
    count = 0
    if not a.no_commands:
        for guide in GUIDES:
            if a.only and not guide.endswith(a.only):
                continue
            with tempfile.TemporaryDirectory(prefix="doc-check-", dir=a.tmp) as tmp_root:
                for prefix in MOVED_PREFIXES:
                    os.makedirs(os.path.dirname(tmp_root + prefix), exist_ok=True)
                work = os.path.join(tmp_root, "work")
                os.makedirs(work)
                runner = Runner(source, bin_dirs, tmp_root)
                cwd = work
                try:
                    commands = extract_commands(os.path.join(source, guide))
                except Failure as e:
                    failures.append(str(e))
                    continue
                for line, text in commands:
                    count += 1
                    t0 = time.monotonic()
                    try:
                        cwd = runner.check(text, cwd)
                    except Failure as e:
                        failures.append(f"{guide}:{line}: {text.strip()}\n  {e}")
                    except subprocess.TimeoutExpired:
                        failures.append(f"{guide}:{line}: {text.strip()}\n  timed out")
                    print(f"{guide}:{line}: {time.monotonic() - t0:5.1f} s  "
                          f"{text.strip().splitlines()[0][:90]}")
    for f in failures:
        print("FAIL: " + f)
    print(f"doc check: {count} commands, {len(failures)} failures, "
          f"{time.monotonic() - start:.1f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
