/* SPDX-License-Identifier: GPL-3.0-or-later */
/* simavr 1.6's IRQ raising, register bits and interrupt raising and clearing (sim_irq.c,
 * sim_regbit.h, sim_interrupts.c), inline and without the calls nobody needs: an IRQ nobody
 * hooks (no trace, no part listens) gets the value and flags simavr's avr_raise_irq_float
 * would give it, without the call; a register bit of an I/O register is written directly
 * unless gdb watches the memory (simavr's avr_core_watch_write then, and for any address it
 * would refuse). A vector simavr traces (its debug printf) goes to simavr's own functions.
 * What they leave is simavr's, byte for byte: the fast core (fast_core.c) enters and leaves
 * interrupts with them, and the USART link (uart_link.c) raises and clears its interrupts with
 * them when its servo runs the fast core; with AX12_SIM_CORE=simavr both use simavr's, the
 * reference the differential test compares against. */
#ifndef SIM_FAST_INTERRUPTS_H
#define SIM_FAST_INTERRUPTS_H

#include <sim_avr.h>
#include <sim_core.h>
#include <sim_interrupts.h>
#include <sim_irq.h>
#include <sim_regbit.h>

DEFINE_FIFO(avr_int_vector_p, avr_int_pending);

/* avr_raise_irq_float(irq, v, floating). */
static inline void fast_irq_raise_float(avr_irq_t *irq, uint32_t v, int floating) {
  if (irq->hook) {
    avr_raise_irq_float(irq, v, floating);
    return;
  }
  const uint32_t out = (irq->flags & IRQ_FLAG_NOT) ? !v : v;
  if (irq->value == out && (irq->flags & IRQ_FLAG_FILTERED) && !(irq->flags & IRQ_FLAG_INIT)) {
    return;
  }
  irq->flags &= ~(IRQ_FLAG_INIT | IRQ_FLAG_FLOATING);
  if (floating) {
    irq->flags |= IRQ_FLAG_FLOATING;
  }
  irq->value = out;
}

/* avr_raise_irq(irq, v): the floating flag kept. Without hooks this always ends with the
 * value set and INIT cleared (when simavr's filter returns early, they already are). */
static inline void fast_irq_raise(avr_irq_t *irq, uint32_t v) {
  if (irq->hook) {
    avr_raise_irq_float(irq, v, !!(irq->flags & IRQ_FLAG_FLOATING));
    return;
  }
  irq->value = (irq->flags & IRQ_FLAG_NOT) ? !v : v;
  irq->flags &= (uint8_t)~IRQ_FLAG_INIT;
}

/* avr_core_watch_write(avr, addr, v). */
static inline void fast_watch_write(avr_t *avr, uint16_t addr, uint8_t v) {
  if (__builtin_expect(avr->gdb != NULL || addr < 32 || addr > avr->ramend, 0)) {
    avr_core_watch_write(avr, addr, v);
    return;
  }
  avr->data[addr] = v;
}

/* avr_regbit_set(avr, rb), avr_regbit_clear(avr, rb) (the latter writes even with no register,
 * as simavr's: a logged crash). */
static inline void fast_regbit_set(avr_t *avr, avr_regbit_t rb) {
  if (rb.reg) {
    fast_watch_write(avr, rb.reg, (uint8_t)(avr->data[rb.reg] | (rb.mask << rb.bit)));
  }
}

static inline void fast_regbit_clear(avr_t *avr, avr_regbit_t rb) {
  fast_watch_write(avr, rb.reg, (uint8_t)(avr->data[rb.reg] & ~(rb.mask << rb.bit)));
}

static inline int fast_pending_any(avr_t *avr) { return !avr_int_pending_isempty(&avr->interrupts.pending); }

/* avr_raise_interrupt(avr, vector). */
static inline int fast_raise_interrupt(avr_t *avr, avr_int_vector_t *vector) {
  if (!vector || !vector->vector) {
    return 0;
  }
  if (__builtin_expect(vector->trace, 0)) {
    return avr_raise_interrupt(avr, vector);
  }
  if (vector->pending) {
    return 0;
  }
  if (vector->raised.reg) {
    fast_regbit_set(avr, vector->raised); /* the flag, even with the interrupt disabled */
  }
  fast_irq_raise(vector->irq + AVR_INT_IRQ_PENDING, 1);
  fast_irq_raise(avr->interrupts.irq + AVR_INT_IRQ_PENDING, 1);
  if (avr_regbit_get(avr, vector->enable)) {
    vector->pending = 1;
    avr_int_pending_write(&avr->interrupts.pending, vector);
    if (avr->sreg[S_I] && avr->interrupt_state == 0) {
      avr->interrupt_state = 1;
    }
    if (avr->state == cpu_Sleeping) {
      avr->state = cpu_Running;
    }
  }
  return 1;
}

/* avr_clear_interrupt(avr, vector). */
static inline void fast_clear_interrupt(avr_t *avr, avr_int_vector_t *vector) {
  if (!vector) {
    return;
  }
  if (__builtin_expect(vector->trace, 0)) {
    avr_clear_interrupt(avr, vector);
    return;
  }
  vector->pending = 0;
  fast_irq_raise(vector->irq + AVR_INT_IRQ_PENDING, 0);
  const int pending = fast_pending_any(avr);
  fast_irq_raise_float(avr->interrupts.irq + AVR_INT_IRQ_PENDING,
                       pending ? avr_int_pending_read_at(&avr->interrupts.pending, 0)->vector : 0, !pending);
  if (vector->raised.reg && !vector->raise_sticky) {
    fast_regbit_clear(avr, vector->raised);
  }
}

#endif
