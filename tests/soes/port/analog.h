/*
 * The board's converters for the SOES port: the AD5663 DAC on SSP0 and the AD7689 ADC on
 * SSP1 (docs/hardware-facts.md sections 4-6).
 */
#ifndef ANALOG_H
#define ANALOG_H

#include <stdint.h>

/* AD5663: power-on state (LDAC register 0: the LDAC pin updates both channels). */
void dac_init (void);
/* Loads both input registers (command 000); the next LDAC pulse updates both outputs. */
void dac_preload (uint16_t a, uint16_t b);
/* Both outputs updated now (input A, then input B with "update all", command 010). */
void dac_write_both (uint16_t a, uint16_t b);
/* LDAC pulse: both DAC registers take their input registers at once. */
void dac_ldac_pulse (void);

/* AD7689: CFG written (unipolar, IN0..IN7 sequence, external reference, no readback) and
 * the sequencer brought to IN0. */
void adc_init (void);
/* One scan of IN0..IN7 (read after conversion, 4 us per conversion): 16-bit codes. */
void adc_scan (uint16_t codes[8]);

#endif /* ANALOG_H */
