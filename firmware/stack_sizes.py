"""The largest stack use of each firmware entry point, from the compiler's
own frame sizes.

usage: python3 stack_sizes.py IMAGE OBJDUMP [ENTRY ...]

IMAGE is the thumbv7em image linked with nightly's `-Z emit-stack-sizes`
and `-T stack-sizes.x` (which keeps the `.stack_sizes` section: one
(function address, frame bytes) pair per function the compiler generated).
OBJDUMP is llvm-objdump, whose disassembly gives the call graph (`bl`, and
`b`/`b.w` to another function's start: a tail call). An entry point's use
is its frame plus the largest use among its callees, over every path,
except that a tail call's callee runs in the caller's place: the callee
returns through `lr` straight to the caller's caller, so the caller has
released its frame before the branch (the epilogue precedes it), and the
callee's use counts from the caller's entry, without the caller's frame.
The deepest path is printed with each function's frame in parentheses,
"tail call:" before a function reached by one (its caller's frame then
counts for nothing below it).

Functions without an entry (compiler-builtins, precompiled without the
flag) get their frame from their prologue (`push`, `vpush`, `sub sp`), and
are named in the output. The walk refuses recursion and indirect calls
(`blx rN`, `bx rN` other than `bx lr`): either would make the bound a guess.
"""
import re
import struct
import subprocess
import sys


def stack_sizes(path):
    """{address: frame bytes} from the ELF32 image's .stack_sizes section."""
    data = open(path, "rb").read()
    if data[:4] != b"\x7fELF" or data[4] != 1 or data[5] != 1:
        sys.exit(f"{path}: not a little-endian 32-bit ELF image")
    shoff, = struct.unpack_from("<I", data, 0x20)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x2E)
    sections = [struct.unpack_from("<IIIIIIIIII", data, shoff + i * shentsize) for i in range(shnum)]
    strtab = sections[shstrndx]
    def name(sh):
        start = strtab[4] + sh[0]
        return data[start:data.index(b"\0", start)].decode()
    found = [sh for sh in sections if name(sh) == ".stack_sizes"]
    if not found:
        sys.exit(f"{path}: no .stack_sizes section (build with -Z emit-stack-sizes and -T stack-sizes.x)")
    sh = found[0]
    sizes, at, end = {}, sh[4], sh[4] + sh[5]
    while at < end:
        addr, = struct.unpack_from("<I", data, at)
        at += 4
        size, shift = 0, 0
        while True:
            byte = data[at]
            at += 1
            size |= (byte & 0x7F) << shift
            shift += 7
            if byte < 0x80:
                break
        sizes[addr & ~1] = size  # the Thumb bit is not part of the address
    return sizes


FUNC = re.compile(r"^([0-9a-f]+) <(.+)>:$")
CALL = re.compile(r"^\s*[0-9a-f]+:\s+(bl|b|b\.w|b\.n)\s+0x([0-9a-f]+)\b")
TAIL = {"b", "b.w", "b.n"}
INDIRECT = re.compile(r"^\s*[0-9a-f]+:\s+(blx|bx)\s+(r\d+|ip|sp)\b")
PUSH = re.compile(r"^\s*[0-9a-f]+:\s+(push(?:\.w)?|vpush)\s+\{(.*)\}")
SUB_SP = re.compile(r"^\s*[0-9a-f]+:\s+sub(?:\.w)?\s+sp,\s+(?:sp,\s+)?#(0x[0-9a-f]+|\d+)")


def functions(image, objdump):
    """{address: [demangled name, callee addresses, has indirect call,
    prologue frame bytes, tail callee addresses]}; callees are calls, tail
    callees branches to another function's first instruction."""
    out = subprocess.run([objdump, "-d", "-C", "--no-show-raw-insn", image], check=True,
                         capture_output=True, text=True).stdout
    funcs, current, targets = {}, None, {}
    for line in out.splitlines():
        m = FUNC.match(line)
        if m:
            current = int(m.group(1), 16)
            funcs[current] = [m.group(2), set(), False, 0, set()]
            targets[current] = set()
            continue
        if current is None:
            continue
        f = funcs[current]
        m = CALL.match(line)
        if m:
            targets[current].add((int(m.group(2), 16), m.group(1) in TAIL))
            continue
        m = INDIRECT.match(line)
        if m:
            f[2] = True
            continue
        m = PUSH.match(line)
        if m:
            regs = [r.strip() for r in m.group(2).split(",")]
            f[3] += sum(8 if r.startswith("d") else 4 for r in regs)
            continue
        m = SUB_SP.match(line)
        if m:
            f[3] += int(m.group(1), 0)
    for addr, ts in targets.items():
        calls = {t for t, tail in ts if t in funcs and t != addr}
        funcs[addr][1] = {t for t in calls if (t, False) in ts}
        funcs[addr][4] = {t for t in calls if (t, True) in ts}
    return funcs


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    image, objdump, entries = sys.argv[1], sys.argv[2], sys.argv[3:]
    sizes = stack_sizes(image)
    funcs = functions(image, objdump)
    estimated = set()

    def frame(addr):
        if addr in sizes:
            return sizes[addr]
        estimated.add(funcs[addr][0])
        return funcs[addr][3]

    memo = {}

    def use(addr, path):
        if addr in path:
            sys.exit("recursion: " + " -> ".join(funcs[a][0] for a in path + [addr]))
        if addr not in memo:
            name, callees, indirect, _, tails = funcs[addr]
            if indirect:
                sys.exit(f"{name} makes an indirect call: its stack use has no static bound here")
            deepest = max((use(c, path + [addr]) for c in callees), default=(0, []))
            own = (frame(addr) + deepest[0], [f"{name} ({frame(addr)})"] + deepest[1])
            for c in tails:
                total, rest = use(c, path + [addr])
                if total > own[0]:
                    own = (total, [f"{name} ({frame(addr)})", "tail call: " + rest[0]] + rest[1:])
            memo[addr] = own
        return memo[addr]

    by_name = {f[0]: a for a, f in funcs.items()}
    for entry in entries or sorted(n for n in by_name if n.startswith("kdray_fw_")):
        if entry not in by_name:
            sys.exit(f"no function {entry} in {image}")
        total, path = use(by_name[entry], [])
        print(f"{entry}: {total} bytes  (deepest path: {' -> '.join(path)})")
    if estimated:
        print("frames read from the prologue (no .stack_sizes entry): " + ", ".join(sorted(estimated)))


if __name__ == "__main__":
    main()
