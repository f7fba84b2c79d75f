/*
 * Reset and vectors of the SOES port on the LPC1754: the vector table (word 7 is the boot
 * ROM's checksum, patched into the ELF after linking), .data copied from flash, .bss
 * cleared, then main.
 */
#include <stdint.h>

extern uint32_t __StackTop;
extern uint32_t __etext, __data_start__, __data_end__, __bss_start__, __bss_end__;

int main (void);
void Reset_Handler (void);
void TIMER1_IRQHandler (void);
void EINT3_IRQHandler (void);

/* An exception the port does not expect: stop here (a debugger shows where). */
static void Default_Handler (void)
{
   for (;;)
   {
   }
}

#define ISR(name) void name (void) __attribute__((weak, alias ("Default_Handler")))
ISR (NMI_Handler);
ISR (HardFault_Handler);
ISR (MemManage_Handler);
ISR (BusFault_Handler);
ISR (UsageFault_Handler);
ISR (SVC_Handler);
ISR (DebugMon_Handler);
ISR (PendSV_Handler);
ISR (SysTick_Handler);

__attribute__((section (".isr_vector"), used))
void (* const vectors[16 + 35]) (void) =
{
   (void (*) (void))&__StackTop,
   Reset_Handler,
   NMI_Handler,
   HardFault_Handler,
   MemManage_Handler,
   BusFault_Handler,
   UsageFault_Handler,
   0, /* vector checksum (UM10360 32.3.1.1), patched after linking */
   0, 0, 0,
   SVC_Handler,
   DebugMon_Handler,
   0,
   PendSV_Handler,
   SysTick_Handler,
   /* IRQ 0..34: TIMER1 (2) is SYNC0, EINT3 (21) the ESC's SPI_IRQ. */
   Default_Handler, Default_Handler, TIMER1_IRQHandler, Default_Handler,
   Default_Handler, Default_Handler, Default_Handler, Default_Handler,
   Default_Handler, Default_Handler, Default_Handler, Default_Handler,
   Default_Handler, Default_Handler, Default_Handler, Default_Handler,
   Default_Handler, Default_Handler, Default_Handler, Default_Handler,
   Default_Handler, EINT3_IRQHandler, Default_Handler, Default_Handler,
   Default_Handler, Default_Handler, Default_Handler, Default_Handler,
   Default_Handler, Default_Handler, Default_Handler, Default_Handler,
   Default_Handler, Default_Handler, Default_Handler,
};

/* Code Read Protection word at 0x2FC: no protection. */
__attribute__((section (".crp"), used))
const uint32_t crp_word = 0xFFFFFFFF;

void Reset_Handler (void)
{
   uint32_t * src = &__etext;
   for (uint32_t * dst = &__data_start__; dst < &__data_end__;)
   {
      *dst++ = *src++;
   }
   for (uint32_t * dst = &__bss_start__; dst < &__bss_end__;)
   {
      *dst++ = 0;
   }
   main ();
   for (;;)
   {
   }
}
