/* Build-time configuration of the protocol core. Every option is always defined (to a
 * number), so a typo is a -Wundef error rather than a silent default. */
#ifndef DXL_CONFIG_H
#define DXL_CONFIG_H

#define DXL_PROFILE_AX12 1  /* the 2006 AX-12 manual */
#define DXL_PROFILE_AX12A 2 /* the later AX-12A e-manual, where docs/policy.md says so */

#ifndef DXL_PROFILE
#define DXL_PROFILE DXL_PROFILE_AX12
#endif
#if DXL_PROFILE != DXL_PROFILE_AX12 && DXL_PROFILE != DXL_PROFILE_AX12A
#error "DXL_PROFILE must be DXL_PROFILE_AX12 or DXL_PROFILE_AX12A"
#endif

/* 1 when the firmware sits beside the bootloader (docs/bootloader.md): it then takes the
 * instruction that enters it (DXL_INST_BOOTLOADER). The builds of firmware/bootable_mcus.cmake's
 * parts; 0 elsewhere. */
#ifndef DXL_HAS_BOOTLOADER
#define DXL_HAS_BOOTLOADER 0
#endif

/* 1 on the host: the link layer reports each packet it handled to dxl_link_port_handled()
 * (the tests' observers, the conformance log). The firmware has no observer. */
#ifndef DXL_LINK_OBSERVER
#if defined(__AVR__)
#define DXL_LINK_OBSERVER 0
#else
#define DXL_LINK_OBSERVER 1
#endif
#endif

/* This firmware's own version number, reported at address 2: one per profile, so a client can
 * tell which build a servo runs (after an update over the bus, docs/bootloader.md). */
#define DXL_FIRMWARE_VERSION_AX12 1
#define DXL_FIRMWARE_VERSION_AX12A 2
#if DXL_PROFILE == DXL_PROFILE_AX12A
#define DXL_FIRMWARE_VERSION DXL_FIRMWARE_VERSION_AX12A
#else
#define DXL_FIRMWARE_VERSION DXL_FIRMWARE_VERSION_AX12
#endif

/* Tables that never change live in flash on the AVR (read with LPM through the __flash
 * named address space of avr-gcc) and in ordinary const memory on the host. */
#if defined(__AVR__)
#define DXL_FLASH __flash
#else
#define DXL_FLASH
#endif

/* A function the AVR build must keep as one copy (link-time inlining would duplicate it into
 * each caller, where flash is what runs out). */
#define DXL_ONE_COPY __attribute__((noinline))

/* DXL_OPAQUE(pointer): on the AVR, hides where pointer points from the optimiser (an empty
 * asm that may change it), so a function reaches the fields of a static object through it
 * with LDD/STD and a displacement (one word) rather than LDS/STS at the object's address (two),
 * which is what link-time constant propagation of &object would give. Nothing on the host. */
#if defined(__AVR__)
#define DXL_OPAQUE(pointer) __asm__("" : "+r"(pointer))
#else
#define DXL_OPAQUE(pointer) ((void)0)
#endif

#endif
