/*
 * AD5663 and AD7689 for the SOES port (see analog.h).
 */
#include "analog.h"
#include "board.h"

/* AD5663 24-bit word: command DB21..19, address DB18..16, data DB15..0. */
#define DAC_CMD_WRITE_INPUT      0u   /* write to input register n */
#define DAC_CMD_WRITE_UPDATE_ALL 2u   /* write to input register n, update all */
#define DAC_CMD_LDAC_SETUP       6u
#define DAC_ADDR_A               0u
#define DAC_ADDR_B               1u

static void dac_frame (uint32_t cmd, uint32_t addr, uint16_t data)
{
   FIO_CLR (2) = DAC_SYNC_BIT;
   SSP_DR (SSP0_BASE) = (cmd << 3) | addr;
   SSP_DR (SSP0_BASE) = (uint32_t)(data >> 8);
   SSP_DR (SSP0_BASE) = (uint32_t)(data & 0xFF);
   while (SSP_SR (SSP0_BASE) & SSP_SR_BSY)
   {
   }
   /* Drain the three bytes SSP0 received (the DAC has no SDO). */
   while (SSP_SR (SSP0_BASE) & SSP_SR_RNE)
   {
      (void)SSP_DR (SSP0_BASE);
   }
   FIO_SET (2) = DAC_SYNC_BIT;
}

void dac_init (void)
{
   /* Both channels follow the LDAC pin. */
   dac_frame (DAC_CMD_LDAC_SETUP, 0, 0);
}

void dac_preload (uint16_t a, uint16_t b)
{
   dac_frame (DAC_CMD_WRITE_INPUT, DAC_ADDR_A, a);
   dac_frame (DAC_CMD_WRITE_INPUT, DAC_ADDR_B, b);
}

void dac_write_both (uint16_t a, uint16_t b)
{
   dac_frame (DAC_CMD_WRITE_INPUT, DAC_ADDR_A, a);
   dac_frame (DAC_CMD_WRITE_UPDATE_ALL, DAC_ADDR_B, b);
}

void dac_ldac_pulse (void)
{
   FIO_CLR (2) = DAC_LDAC_BIT;
   FIO_SET (2) = DAC_LDAC_BIT;
}

/* AD7689 CFG: overwrite, unipolar referenced to GND (INCC 111), sequence IN0..IN7
 * (INx 111), full bandwidth, external reference (REF 111), scan without the temperature
 * (SEQ 11), no readback. */
#define ADC_CFG   ((1u << 13) | (7u << 10) | (7u << 7) | (1u << 6) | (7u << 3) | (3u << 1) | 1u)
/* tCONV (2.2 us max) before the read; tCYC 4 us between conversions. */
#define ADC_TCONV_NS   2300u
#define ADC_TCYC_TICKS 400u

static uint32_t last_cnv;

/* One conversion: CNV high (MAT2.0 through EMR) starts it, CNV low after tCONV, then the
 * 16 SCK that read it (and write `din`). */
static uint16_t adc_convert (uint16_t din)
{
   while ((uint32_t)(board_ticks () - last_cnv) < ADC_TCYC_TICKS)
   {
   }
   TIM_EMR (TIM2_BASE) = 1;
   last_cnv = board_ticks ();
   board_delay_ns (ADC_TCONV_NS);
   TIM_EMR (TIM2_BASE) = 0;
   SSP_DR (SSP1_BASE) = din;
   while ((SSP_SR (SSP1_BASE) & SSP_SR_RNE) == 0)
   {
   }
   return (uint16_t)SSP_DR (SSP1_BASE);
}

void adc_init (void)
{
   last_cnv = board_ticks () - ADC_TCYC_TICKS;
   /* The power-up conversion's frame carries the CFG; the conversion after it resets
    * the sequencer to IN0. */
   (void)adc_convert ((uint16_t)(ADC_CFG << 2));
   (void)adc_convert (0);
}

void adc_scan (uint16_t codes[8])
{
   for (int ch = 0; ch < 8; ch++)
   {
      codes[ch] = adc_convert (0);
   }
}
