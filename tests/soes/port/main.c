/*
 * SOES on the thesis board: the analog I/O module (2 AO, 8 AI, INTEGER16, CiA 401 objects
 * 0x6411 and 0x6401) with DC SYNC0, structured as SOES's interrupt-driven applications
 * (soes/hal/rt-kernel-xmc4): the PDI and SYNC0 interrupts run the process data
 * (esc_hw.c), ecat_slv_worker serves the state machine and the mailbox in the main loop.
 *
 * Outputs: the PDI interrupt's cb_set_outputs loads both AD5663 input registers, the
 * application hook that SOES runs at SYNC0 pulses LDAC, so both outputs change together at
 * the SYNC0 edge. Inputs: at SYNC0, cb_get_inputs takes the last AD7689 scan and asks the
 * main loop for the next one (8 conversions, 4 us apart).
 */
#include <string.h>
#include "ecat_slv.h"
#include "esc_hw.h"
#include "utypes.h"
#include "board.h"
#include "analog.h"

/* SOES reads the SYNC0 cycle time (esc.c; not in esc.h). */
uint32_t ESC_SYNC0cycletime (void);

/* Application variables */
_Objects    Obj;

static uint16_t adc_codes[8];
static volatile uint8_t adc_scan_request;

/* INTEGER16 0..0x7FFF spans the outputs' 0..10 V (DAC codes 0..0xFFFE); below 0 is 0 V. */
static uint16_t dac_code (int16_t value)
{
   return value < 0 ? 0 : (uint16_t)((uint16_t)value << 1);
}

void cb_get_inputs (void)
{
   /* 0..10 V at the input is ADC code 0..0xFFFF, INTEGER16 0..0x7FFF. */
   for (int ch = 0; ch < 8; ch++)
   {
      Obj.AnalogInput[ch] = (int16_t)(adc_codes[ch] >> 1);
   }
   adc_scan_request = 1;
}

void cb_set_outputs (void)
{
   /* An LDAC pulse between the two frames would latch half a pair. */
   uint32_t primask = irq_save ();
   dac_preload (dac_code (Obj.AnalogOutput[0]), dac_code (Obj.AnalogOutput[1]));
   irq_restore (primask);
}

/* Run by DIG_process at SYNC0 (and after the outputs in SM-synchronous mode). */
static void sync0_application (void)
{
   dac_ldac_pulse ();
}

/* Outputs stopped (OP left, SM watchdog, sync error): 0 V on both. */
static void safe_outputs (void)
{
   dac_write_both (0, 0);
}

/* Setup of DC: the SYNC0 cycle is one the port sustains (0x1C32:05). */
static uint16_t dc_checker (void)
{
   uint32_t cycle = ESC_SYNC0cycletime ();
   if (cycle < Obj.SyncManagerOutput.MinimumCycleTime)
   {
      return ALERR_DCSYNC0CYCLETIME;
   }
   Obj.SyncManagerOutput.CycleTime = cycle;
   Obj.SyncManagerInput.CycleTime = cycle;
   /* Indicate we run DC */
   ESCvar.dcsync = 1;
   /* Fetch the sync counter limit  SDO10F1*/
   ESCvar.synccounterlimit = Obj.ErrorSettings.SyncErrorCounterLimit;
   return 0;
}

int main (void)
{
   static esc_cfg_t config =
   {
      .user_arg = NULL,
      .use_interrupt = 1,
      .watchdog_cnt = INT32_MAX, /* Use HW SM watchdog instead */
      .set_defaults_hook = NULL,
      .pre_state_change_hook = NULL,
      .post_state_change_hook = NULL,
      .application_hook = sync0_application,
      .safeoutput_override = safe_outputs,
      .pre_object_download_hook = NULL,
      .post_object_download_hook = NULL,
      .rxpdo_override = NULL,
      .txpdo_override = NULL,
      .esc_hw_interrupt_enable = ESC_interrupt_enable,
      .esc_hw_interrupt_disable = ESC_interrupt_disable,
      .esc_hw_eep_handler = NULL,
      .esc_check_dc_handler = dc_checker,
   };

   (void)board_clock_init ();
   board_init ();
   dac_init ();
   adc_init ();

   ecat_slv_init (&config);

   for (;;)
   {
      /* Sleep until an interrupt has work for the main loop (WFI wakes on a pending
       * interrupt with PRIMASK set; the handler runs at irq_restore). */
      uint32_t primask = irq_save ();
      if (!esc_worker_pending && !adc_scan_request)
      {
         __asm volatile ("wfi");
      }
      irq_restore (primask);

      if (esc_worker_pending)
      {
         esc_worker_pending = 0;
         ecat_slv_worker (ESC_WORKER_EVENTS);
      }
      if (adc_scan_request)
      {
         uint16_t codes[8];
         adc_scan_request = 0;
         adc_scan (codes);
         primask = irq_save ();
         memcpy (adc_codes, codes, sizeof (codes));
         irq_restore (primask);
      }
   }
}
