"""scripts/bench --sizes: the firmware's sizes, one table in docs/firmware.md ("Sizes"), written
between its markers (--check: exit 1 when the table there differs from the build's, nothing
written). Per ELF: flash (.text + .data) and static RAM (avr-size), and for the ATmega88
applications the deepest stack (ax12-bench stack) and RAM with stack and the nesting margin
against the 768 B budget. Per source file: flash of the ATmega328P application built without
link-time optimisation (flash_by_module). The code states contracts; the sizes live here."""
import os
import re
import subprocess
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))
import ax12_fuses  # noqa: E402
DOC = os.path.join(REPO, "docs", "firmware.md")
BEGIN = "<!-- sizes: written by scripts/bench --sizes, checked by scripts/bench --sizes --check -->"
END = "<!-- /sizes -->"

# What a part's application may use (python/ax12_fuses.py's part facts): up to the record below
# the 512 B boot section (docs/bootloader.md).
APP_BUDGET = {name: mcu.app_limit_bytes for name, mcu in ax12_fuses.MCUS.items()}
RAM_BUDGET_ATMEGA88 = 768  # static RAM + deepest stack + nesting margin (docs/firmware.md)
NESTING_MARGIN = 14  # TIMER1_COMPB's frame and the ISR nested in it (docs/firmware.md)


def avr_size(elf):
    """(flash, static RAM) of an ELF: .text + .data, .data + .bss + .noinit."""
    out = subprocess.run(["avr-size", "-A", elf], check=True, capture_output=True, text=True).stdout
    sections = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sections[parts[0]] = int(parts[1])
    flash = sections.get(".text", 0) + sections.get(".data", 0)
    ram = sections.get(".data", 0) + sections.get(".bss", 0) + sections.get(".noinit", 0)
    return flash, ram


def flash_by_module(build):
    """Flash each firmware source file costs on its own: the ATmega328P build compiled without
    link-time optimisation (AX12_FIRMWARE_LTO=OFF, in <build>/firmware-by-module), its map's
    .text/.data input sections summed per object file. LTO then shares and inlines across files:
    the product image is smaller than the sum. Returns [(module, bytes)], largest first, and the
    total."""
    out = os.path.join(build, "firmware-by-module")
    subprocess.run(["cmake", "-S", os.path.join(REPO, "firmware"), "-B", out, "-DAVR_MCU=atmega328p",
                    "-DDXL_PROFILE_NAME=ax12", "-DAX12_FIRMWARE_LTO=OFF"], check=True, capture_output=True)
    subprocess.run(["cmake", "--build", out], check=True, capture_output=True)
    sizes = {}
    pending = None  # a section name on its own line: its address, size and object follow
    with open(os.path.join(out, "ax12-ax12-atmega328p.map")) as f:
        text = f.read()
    text = text[text.index("Linker script and memory map"):]
    for line in text.splitlines():
        m = re.match(r"^ (\.(?:text|data|progmem|init\d|vectors)\S*)\s*$", line)
        if m:
            pending = m.group(1)
            continue
        m = re.match(r"^ (\.(?:text|data|progmem|init\d|vectors)\S*)?\s+0x[0-9a-f]+\s+0x([0-9a-f]+)\s+(\S+)", line)
        if m and (m.group(1) or pending):
            obj = m.group(3)
            name = re.sub(r"\.(c|S)\.obj$", r".\1", os.path.basename(obj))
            name = re.sub(r"^lib(gcc|c|atmega328p)\.a\(.*\)$", r"lib\1", name)
            name = "vectors and C runtime" if name.startswith("crt") else name
            sizes[name] = sizes.get(name, 0) + int(m.group(2), 16)
        pending = None
    total = sum(sizes.values())
    return sorted(sizes.items(), key=lambda kv: -kv[1]), total


def stack_bytes(bench, elf):
    out = subprocess.run([bench, "stack", elf], check=True, capture_output=True, text=True).stdout
    return int(re.search(r'"stack_deepest_bytes":\s*(\d+)', out).group(1))


def sizes_table(build):
    """The markdown of the table (without the markers)."""
    fw = os.path.join(build, "firmware")
    bench = os.path.join(build, "model", "tools", "ax12-bench")
    lines = ["| ELF | flash | static RAM | deepest stack | RAM + stack + %d B nesting |" % NESTING_MARGIN,
             "|---|---|---|---|---|"]
    for mcu in ("atmega88", "atmega328p"):
        for profile in ("ax12", "ax12a"):
            elf = os.path.join(fw, "ax12-%s-%s.elf" % (profile, mcu))
            flash, ram = avr_size(elf)
            cells = ["`ax12-%s-%s`" % (profile, mcu), "%d B of %d" % (flash, APP_BUDGET[mcu]), "%d B" % ram]
            if mcu == "atmega88":
                stack = stack_bytes(bench, elf)
                cells += ["%d B" % stack, "%d B of %d" % (ram + stack + NESTING_MARGIN, RAM_BUDGET_ATMEGA88)]
            else:
                cells += ["", ""]
            lines.append("| " + " | ".join(cells) + " |")
    for mcu in ("atmega88", "atmega328p"):
        boot = os.path.join(fw, "ax12-boot-%s.elf" % mcu)
        flash, ram = avr_size(boot)
        lines.append("| `ax12-boot-%s` | %d B of its %d B boot section | %d B | | |"
                     % (mcu, flash, ax12_fuses.BOOT_SECTION_BYTES, ram))
    modules, total = flash_by_module(build)
    lines += ["", "| source file (ATmega328P, ax12, without LTO) | flash |", "|---|---|"]
    lines += ["| `%s` | %d B |" % (name, size) for name, size in modules]
    lines.append("| sum (LTO shares and inlines across them: the product is smaller) | %d B |" % total)
    return "\n".join(lines)


def run(build, check):
    """Writes the table into docs/firmware.md, or with check says whether it is there as is.
    Returns the exit status."""
    with open(DOC) as f:
        doc = f.read()
    if BEGIN not in doc or END not in doc:
        print("bench --sizes: %s has no %s ... %s" % (DOC, BEGIN, END))
        return 1
    head, rest = doc.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    table = sizes_table(build)
    new = head + BEGIN + "\n" + table + "\n" + END + tail
    print(table)
    if check:
        if new != doc:
            print("\nbench --sizes --check: docs/firmware.md's table differs from the build (scripts/bench --sizes "
                  "writes it)")
            return 1
        print("\nbench --sizes --check: docs/firmware.md's table is the build's")
        return 0
    if new != doc:
        with open(DOC, "w") as f:
            f.write(new)
        print("\nbench --sizes: wrote the table of docs/firmware.md")
    return 0
