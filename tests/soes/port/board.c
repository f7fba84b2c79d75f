/*
 * Board bring-up for the SOES port: clocks, pins, SPI/SSP, timers (see board.h).
 */
#include "board.h"

#define XTAL_PLL0CFG      ((5u << 16) | 99u) /* 12 MHz: M = 100, N = 6 -> FCCO 400 MHz */
#define XTAL_CCLKCFG      3u                 /* 400 / 4 = 100 MHz */
#define IRC_PLL0CFG       ((1u << 16) | 74u) /* 4 MHz: M = 75, N = 2 -> FCCO 300 MHz */
#define IRC_CCLKCFG       2u                 /* 300 / 3 = 100 MHz */
#define FLASHCFG_SAFE     0x503Au
#define FLASHCFG_100MHZ   0x403Au            /* 5 CPU clocks, up to 100 MHz */
#define SCS_OSCEN         (1u << 5)
#define SCS_OSCSTAT       (1u << 6)
#define PLL0STAT_PLOCK    (1u << 26)
#define PLL0STAT_CONNECTED ((1u << 24) | (1u << 25))
#define POLLS             100000u

static void pll0_feed (void)
{
   SC_PLL0FEED = 0xAA;
   SC_PLL0FEED = 0x55;
}

static bool wait_set (volatile uint32_t * reg, uint32_t bits)
{
   for (uint32_t i = 0; i < POLLS; i++)
   {
      if ((*reg & bits) == bits)
      {
         return true;
      }
   }
   return false;
}

bool board_clock_init (void)
{
   SC_FLASHCFG = FLASHCFG_SAFE;
   /* Peripheral clocks at CCLK (PCLKSEL only while PLL0 is disconnected):
    * TIMER1, SPI, SSP1 in PCLKSEL0; SSP0, TIMER2 in PCLKSEL1. */
   SC_PCLKSEL0 = (SC_PCLKSEL0 & ~((3u << 4) | (3u << 16) | (3u << 20)))
                 | (1u << 4) | (1u << 16) | (1u << 20);
   SC_PCLKSEL1 = (SC_PCLKSEL1 & ~((3u << 10) | (3u << 12))) | (1u << 10) | (1u << 12);

   SC_SCS = SCS_OSCEN;
   bool crystal = wait_set (&SC_SCS, SCS_OSCSTAT);
   SC_CLKSRCSEL = crystal ? 1u : 0u;
   SC_PLL0CFG = crystal ? XTAL_PLL0CFG : IRC_PLL0CFG;
   pll0_feed ();
   SC_PLL0CON = 1; /* enable */
   pll0_feed ();
   SC_CCLKCFG = crystal ? XTAL_CCLKCFG : IRC_CCLKCFG;
   if (!wait_set (&SC_PLL0STAT, PLL0STAT_PLOCK))
   {
      return false;
   }
   SC_PLL0CON = 3; /* enable and connect */
   pll0_feed ();
   if (!wait_set (&SC_PLL0STAT, PLL0STAT_CONNECTED))
   {
      return false;
   }
   SC_FLASHCFG = FLASHCFG_100MHZ;
   return true;
}

/* PINSEL function `fn` for port.pin. */
static void pin_function (uint32_t port, uint32_t pin, uint32_t fn)
{
   uint32_t reg = 2u * port + pin / 16u;
   uint32_t shift = 2u * (pin % 16u);
   PINSEL (reg) = (PINSEL (reg) & ~(3u << shift)) | (fn << shift);
}

void board_delay_ns (uint32_t ns)
{
   uint32_t start = board_ticks ();
   uint32_t ticks = ns / 10u;
   while ((uint32_t)(board_ticks () - start) < ticks)
   {
   }
}

void board_init (void)
{
   SC_PCONP |= PCONP_TIM1 | PCONP_SPI | PCONP_SSP1 | PCONP_GPIO | PCONP_SSP0 | PCONP_TIM2;

   /* Outputs at their idle levels before they become outputs. */
   FIO_SET (ESC_SEL_PORT) = ESC_SEL_BIT;
   FIO_DIR (ESC_SEL_PORT) |= ESC_SEL_BIT;
   FIO_SET (2) = DAC_SYNC_BIT | DAC_LDAC_BIT | DAC_CLR_BIT;
   FIO_DIR (2) |= DAC_SYNC_BIT | DAC_LDAC_BIT | DAC_CLR_BIT;

   /* ET1100: legacy SPI on P0.15/17/18, SEL P0.16 GPIO, IRQ P0.22 GPIO, SYNC0 CAP1.0. */
   pin_function (0, 15, 3);
   pin_function (0, 17, 3);
   pin_function (0, 18, 3);
   pin_function (1, 18, 3);
   /* AD5663 on SSP0 (P1.20 SCK0, P1.23 MISO0, P1.24 MOSI0). */
   pin_function (1, 20, 3);
   pin_function (1, 23, 3);
   pin_function (1, 24, 3);
   /* AD7689 on SSP1 (P0.7 SCK1, P0.8 MISO1, P0.9 MOSI1), CNV = MAT2.0 on P0.6. */
   pin_function (0, 7, 2);
   pin_function (0, 8, 2);
   pin_function (0, 9, 2);
   pin_function (0, 6, 3);

   /* Legacy SPI: master, mode 3 (CPOL = CPHA = 1), 8 bits, PCLK / 8 = 12.5 MHz. */
   S0SPCCR = 8;
   S0SPCR = SPCR_MSTR | SPCR_CPOL | SPCR_CPHA;

   /* SSP0: 8-bit frames, mode 1 (CPOL 0, CPHA 1), 100 MHz / (2 x 2) = 25 MHz. */
   SSP_CPSR (SSP0_BASE) = 2;
   SSP_CR0 (SSP0_BASE) = 7u | (1u << 7) | (1u << 8);
   SSP_CR1 (SSP0_BASE) = SSP_CR1_SSE;

   /* SSP1: 16-bit frames, mode 0, 100 MHz / (2 x 3) = 16.7 MHz. */
   SSP_CPSR (SSP1_BASE) = 2;
   SSP_CR0 (SSP1_BASE) = 15u | (2u << 8);
   SSP_CR1 (SSP1_BASE) = SSP_CR1_SSE;

   /* Timer2 free-running at PCLK (the delays); MAT2.0 (= CNV) driven through EMR only. */
   TIM_PR (TIM2_BASE) = 0;
   TIM_MCR (TIM2_BASE) = 0;
   TIM_EMR (TIM2_BASE) = 0;
   TIM_TCR (TIM2_BASE) = 1;
}
