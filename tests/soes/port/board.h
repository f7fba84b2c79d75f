/*
 * The thesis board's wiring for the SOES port, in one place (docs/hardware-facts.md
 * section 10.A, as firmware/src/platform/hw/board.rs wires it):
 *
 *   ET1100 SPI        P0.15 SCK, P0.17 MISO, P0.18 MOSI (legacy SPI, fn 3), mode 3, 12.5 MHz
 *   ET1100 SPI_SEL    P0.16 GPIO out, idle high
 *   ET1100 SPI_IRQ    P0.22 GPIO in, falling-edge GPIO interrupt (EINT3 vector)
 *   ET1100 SYNC0      P1.18 CAP1.0 (fn 3), Timer1 capture on the rising edge (TIMER1 vector)
 *   ET1100 EEPROM_LOADED P2.4 GPIO in
 *   AD5663            P1.20 SCK0, P1.24 MOSI0 (SSP0, fn 3), mode 1, 25 MHz;
 *                     SYNC P2.2, LDAC P2.3, CLR P2.6 GPIO out
 *   AD7689            P0.7 SCK1, P0.8 MISO1, P0.9 MOSI1 (SSP1, fn 2), mode 0, 16-bit,
 *                     16.7 MHz; CNV = MAT2.0 on P0.6 (fn 3)
 */
#ifndef BOARD_H
#define BOARD_H

#include <stdbool.h>
#include <stdint.h>
#include "lpc17xx_regs.h"

#define CCLK_HZ           100000000u

#define ESC_SEL_PORT      0
#define ESC_SEL_BIT       (1u << 16)
#define ESC_IRQ_PORT      0
#define ESC_IRQ_BIT       (1u << 22)
#define ESC_LOADED_PORT   2
#define ESC_LOADED_BIT    (1u << 4)
#define DAC_SYNC_BIT      (1u << 2)    /* P2.2 */
#define DAC_LDAC_BIT      (1u << 3)    /* P2.3 */
#define DAC_CLR_BIT       (1u << 6)    /* P2.6 */

/* Clocks to 100 MHz from the 12 MHz crystal (the IRC when it does not start), the
 * peripheral clocks at CCLK. Returns false when PLL0 does not lock (CCLK stays 4 MHz). */
bool board_clock_init (void);

/* Pins, peripheral power, the legacy SPI, SSP0, SSP1, Timer2 as a free-running clock. */
void board_init (void);

/* Timer2's counter: 100 MHz ticks (10 ns). */
static inline uint32_t board_ticks (void)
{
   return TIM_TC (TIM2_BASE);
}

/* Busy-waits `ns` nanoseconds on Timer2. */
void board_delay_ns (uint32_t ns);

/* One byte over the legacy SPI (polls SPIF). */
static inline uint8_t board_spi_byte (uint8_t out)
{
   S0SPDR = out;
   while ((S0SPSR & SPSR_SPIF) == 0)
   {
   }
   return (uint8_t)S0SPDR;
}

static inline void board_esc_select (void)
{
   FIO_CLR (ESC_SEL_PORT) = ESC_SEL_BIT;
}

static inline void board_esc_unselect (void)
{
   FIO_SET (ESC_SEL_PORT) = ESC_SEL_BIT;
}

/* The ESC's SPI_IRQ line is asserted (active low). */
static inline bool board_esc_irq_asserted (void)
{
   return (FIO_PIN (ESC_IRQ_PORT) & ESC_IRQ_BIT) == 0;
}

static inline bool board_esc_eeprom_loaded (void)
{
   return (FIO_PIN (ESC_LOADED_PORT) & ESC_LOADED_BIT) != 0;
}

#endif /* BOARD_H */
