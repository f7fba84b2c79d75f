/*
 * ESC hardware layer for an ET1100 on the LPC1754's legacy SPI (the thesis board).
 *
 * The SPI access is SOES's soes/hal/rt-kernel-twrk60/esc_hw.c: 2-byte addressing, read
 * command 0x02, MOSI 0x00 during a read and 0xFF on its last byte, and the AL event bits
 * the ESC shifts out during the address phase stored in ESCvar.ALevent. Each access runs
 * with interrupts disabled, since the SYNC0 and PDI interrupts use the same SPI as the
 * worker in the main loop.
 *
 * The interrupts follow SOES's soes/hal/rt-kernel-xmc4/esc_hw.c: the SYNC0 interrupt runs
 * DIG_process (APP_HOOK | INPUTS) and checks the sync counter; the PDI interrupt runs
 * DIG_process (OUTPUTS) on SM2 in DC mode (everything in SM-synchronous mode), serves the
 * SM watchdog, and hands the AL control, SM change and mailbox events to ecat_slv_worker
 * with them masked until the worker is done.
 */
#include <string.h>
#include "esc.h"
#include "ecat_slv.h"
#include "board.h"
#include "esc_hw.h"

#define MAX_READ_SIZE   128

#define ESC_CMD_READ    0x02
#define ESC_CMD_WRITE   0x04

volatile uint8_t esc_worker_pending;

static uint8_t read_termination[MAX_READ_SIZE] = { 0 };

static void spi_transfer (uint8_t * in, const uint8_t * out, uint16_t len)
{
   for (uint16_t i = 0; i < len; i++)
   {
      uint8_t b = board_spi_byte (out[i]);
      if (in != NULL)
      {
         in[i] = b;
      }
   }
}

static void esc_address (uint16_t address, uint8_t command)
{
   /* Device is selected already. We use 2 bytes addressing. */
   uint8_t data[2];
   uint8_t events[2];

   /* address 12:5 */
   data[0] = (uint8_t)(address >> 5);
   /* address 4:0 and cmd 2:0 */
   data[1] = (uint8_t)(((address & 0x1F) << 3) | command);

   /* Write (and read AL interrupt register) */
   spi_transfer (events, data, sizeof (data));
   ESCvar.ALevent = (ESCvar.ALevent & 0xFFFF0000u) |
                    etohs ((uint16_t)(events[0] | (events[1] << 8)));
}

/** ESC read function used by the Slave stack.
 *
 * @param[in]   address     = address of ESC register to read
 * @param[out]  buf         = pointer to buffer to read in
 * @param[in]   len         = number of bytes to read
 */
void ESC_read (uint16_t address, void *buf, uint16_t len)
{
   uint32_t primask;

   CC_ASSERT (len <= MAX_READ_SIZE);
   primask = irq_save ();
   board_esc_select ();
   esc_address (address, ESC_CMD_READ);
   /* MOSI low (0x00) during all bytes except the last one (0xFF). */
   spi_transfer (buf, read_termination + (MAX_READ_SIZE - len), len);
   board_esc_unselect ();
   irq_restore (primask);
}

/** ESC write function used by the Slave stack.
 *
 * @param[in]   address     = address of ESC register to write
 * @param[out]  buf         = pointer to buffer to write from
 * @param[in]   len         = number of bytes to write
 */
void ESC_write (uint16_t address, void *buf, uint16_t len)
{
   uint32_t primask = irq_save ();
   board_esc_select ();
   esc_address (address, ESC_CMD_WRITE);
   spi_transfer (NULL, buf, len);
   board_esc_unselect ();
   irq_restore (primask);
}

/* The ET1100 has its EEPROM: nothing to reset here. */
void ESC_reset (void)
{
}

/* Bounded wait for EEPROM_LOADED (the PDI answers only after it): 100 ms. */
static void wait_eeprom_loaded (void)
{
   uint32_t start = board_ticks ();
   while (!board_esc_eeprom_loaded () &&
          (uint32_t)(board_ticks () - start) < 100u * 100000u)
   {
   }
}

void ESC_init (const esc_cfg_t * config)
{
   read_termination[MAX_READ_SIZE - 1] = 0xFF;
   wait_eeprom_loaded ();

   if (config->use_interrupt != 0)
   {
      /* The worker's events and the SM watchdog raise SPI_IRQ. */
      ESC_ALeventmaskwrite (ESC_WORKER_EVENTS | ESCREG_ALEVENT_WD);

      /* SPI_IRQ: falling edge of P0.22 (EINT3 vector), below SYNC0's priority. */
      IO0_INT_CLR = ESC_IRQ_BIT;
      IO0_INT_EN_F |= ESC_IRQ_BIT;
      NVIC_IPR (IRQ_EINT3) = 2u << 3;
      NVIC_ICPR = 1u << IRQ_EINT3;
      NVIC_ISER = 1u << IRQ_EINT3;

      /* SYNC0: Timer1 captures CAP1.0's rising edge with an interrupt; the stack
       * enables the interrupt when it runs DC (ESC_interrupt_enable). */
      TIM_CCR (TIM1_BASE) = (1u << 0) | (1u << 2);
      TIM_TCR (TIM1_BASE) = 1;
      NVIC_IPR (IRQ_TIMER1) = 1u << 3;

      /* Events already pending raised the line before the edge was enabled. */
      if (board_esc_irq_asserted ())
      {
         esc_worker_pending = 1;
      }
   }
}

/** ESC interrupt enable function by the Slave stack in IRQ mode.
 *
 * @param[in]   mask     = of interrupts to enable
 */
void ESC_interrupt_enable (uint32_t mask)
{
   if (ESCREG_ALEVENT_DC_SYNC0 & mask)
   {
      mask &= ~ESCREG_ALEVENT_DC_SYNC0;
      TIM_IR (TIM1_BASE) = TIM_IR_CR0;
      NVIC_ICPR = 1u << IRQ_TIMER1;
      NVIC_ISER = 1u << IRQ_TIMER1;
   }
   /* Process data flows again: watch the SM watchdog again. */
   ESC_ALeventmaskwrite (ESC_ALeventmaskread () | mask | ESCREG_ALEVENT_WD);
}

/** ESC interrupt disable function by the Slave stack in IRQ mode.
 *
 * @param[in]   mask     = interrupts to disable
 */
void ESC_interrupt_disable (uint32_t mask)
{
   if (ESCREG_ALEVENT_DC_SYNC0 & mask)
   {
      mask &= ~ESCREG_ALEVENT_DC_SYNC0;
      NVIC_ICER = 1u << IRQ_TIMER1;
   }
   ESC_ALeventmaskwrite (ESC_ALeventmaskread () & ~mask);
}

/** SYNC0 ISR handler (Timer1 capture of CAP1.0).
 */
void TIMER1_IRQHandler (void)
{
   TIM_IR (TIM1_BASE) = TIM_IR_CR0;

   /* Subtract the sync counter to check the pace compared to the SM IRQ */
   if ((CC_ATOMIC_GET (ESCvar.App.state) & APPSTATE_OUTPUT) > 0)
   {
      CC_ATOMIC_SUB (ESCvar.synccounter, 1);
   }
   /* Check so we're inside the limit */
   if ((CC_ATOMIC_GET (ESCvar.synccounter) < -ESCvar.synccounterlimit) ||
       (CC_ATOMIC_GET (ESCvar.synccounter) > ESCvar.synccounterlimit))
   {
      if ((CC_ATOMIC_GET (ESCvar.App.state) & APPSTATE_OUTPUT) > 0)
      {
         ESC_ALstatusgotoerror ((ESCsafeop | ESCerror), ALERR_SYNCERROR);
         CC_ATOMIC_SET (ESCvar.synccounter, 0);
      }
   }
   DIG_process (DIG_PROCESS_APP_HOOK_FLAG | DIG_PROCESS_INPUTS_FLAG);
}

/** PDI ISR handler (SPI_IRQ, falling edge of P0.22).
 */
void EINT3_IRQHandler (void)
{
   IO0_INT_CLR = ESC_IRQ_BIT;
   /* SPI_IRQ is a level (AL event request & mask) on an edge-triggered input: serve
    * until the line is released, or an event arriving meanwhile would raise no edge. */
   do
   {
      /* The local time, and the AL events from the address phase. */
      ESC_read (ESCREG_LOCALTIME, (void *)&ESCvar.Time, sizeof (ESCvar.Time));
      ESCvar.Time = etohl (ESCvar.Time);

      /* Handle SM2 & SM3 interrupt */
      if (ESCvar.ALevent & (ESCREG_ALEVENT_SM2 | ESCREG_ALEVENT_SM3))
      {
         /* Is DC active or not */
         if (ESCvar.dcsync == 0)
         {
            DIG_process (DIG_PROCESS_OUTPUTS_FLAG | DIG_PROCESS_APP_HOOK_FLAG |
                         DIG_PROCESS_INPUTS_FLAG);
         }
         else
         {
            /* Add the sync counter to check the pace compared to the SM IRQ */
            if ((CC_ATOMIC_GET (ESCvar.App.state) & APPSTATE_OUTPUT) > 0)
            {
               CC_ATOMIC_ADD (ESCvar.synccounter, 1);
            }
            DIG_process (DIG_PROCESS_OUTPUTS_FLAG);
         }
      }

      /* Handle low prio interrupts */
      if (ESCvar.ALevent & ESC_WORKER_EVENTS)
      {
         /* Mask interrupts while servicing them */
         ESC_ALeventmaskwrite (ESC_ALeventmaskread () & ~ESC_WORKER_EVENTS);
         esc_worker_pending = 1;
      }

      /* SM watchdog */
      if (ESCvar.ALevent & ESCREG_ALEVENT_WD)
      {
         /* Ack the WD IRQ */
         uint8_t wd = ESC_WDstatus ();
         /* Check if the WD have expired and if we're in OP */
         if (((wd & 0x1) == 0) &&
             ((CC_ATOMIC_GET (ESCvar.App.state) & APPSTATE_OUTPUT) > 0))
         {
            ESC_ALstatusgotoerror ((ESCsafeop | ESCerror), ALERR_WATCHDOG);
            ESC_ALeventmaskwrite (ESC_ALeventmaskread () & ~ESCREG_ALEVENT_WD);
         }
      }
   } while (board_esc_irq_asserted ());
}
