/*
 * ESC hardware layer of the SOES port: an ET1100 on the LPC1754's legacy SPI, after
 * SOES's soes/hal/rt-kernel-twrk60 layer, with the interrupt structure of SOES's
 * soes/hal/rt-kernel-xmc4 layer.
 */
#ifndef ESC_HW_H
#define ESC_HW_H

#include <stdint.h>

/* The AL events ecat_slv_worker serves (the "low priority" ones of the xmc4 layer). */
#define ESC_WORKER_EVENTS (ESCREG_ALEVENT_CONTROL | ESCREG_ALEVENT_SMCHANGE | \
                           ESCREG_ALEVENT_SM0 | ESCREG_ALEVENT_SM1 | ESCREG_ALEVENT_EEP)

/* Set by the PDI interrupt when the worker has events to serve (the xmc4 layer's
 * semaphore); the main loop runs ecat_slv_worker. */
extern volatile uint8_t esc_worker_pending;

void ESC_interrupt_enable (uint32_t mask);
void ESC_interrupt_disable (uint32_t mask);

#endif /* ESC_HW_H */
